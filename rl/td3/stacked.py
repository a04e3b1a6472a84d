"""``M`` networks of one shape as one computation (:class:`StackedMLP`), and the conversions of a
member's weights and Adam moments to and from the plain ``nn.Sequential`` naming, so that the
seeds :class:`~elastica_magnetic_rl.td3.algorithm.TD3` trains side by side are saved, loaded and resumed one
by one as if each had been trained alone."""

from __future__ import annotations

from typing import Any

import torch
import torch.nn as nn

__all__ = ["StackedMLP", "load_member_adam_state", "member_adam_state", "prefixed", "unprefixed"]


#: Floats per vector of the optimizer's fused kernel (AVX-512): each member's share of a stacked
#: parameter is padded to a whole number of them (see :class:`StackedMLP`).
MEMBER_ALIGN = 16


def _padded(rows: int, out: int) -> int:
    """The smallest width ``>= out`` whose ``rows x width`` block is a whole number of
    :data:`MEMBER_ALIGN` floats."""
    width = out
    while (rows * width) % MEMBER_ALIGN:
        width += 1
    return width


class StackedMLP(nn.Module):
    """``M`` MLPs of one shape evaluated as one computation: layer ``l`` holds ``weights[l]``
    ``(M, in, out)`` and ``biases[l]`` ``(M, 1, out)``; :meth:`forward` maps ``(M, B, in)`` to
    ``(M, B, out)`` with one batched matrix product per layer (ReLU between layers). With
    ``layer_norm``, each hidden layer's output is normalised over its features and scaled by
    ``norm_gains[l]`` ``(M, 1, out)`` plus ``norm_biases[l]`` before the ReLU (as ``nn.LayerNorm``,
    eps ``1e-5``).

    Member ``m`` is an ordinary ``nn.Linear`` MLP (:func:`mlp`) whose ``weight`` is
    ``weights[l][m].T`` (:meth:`member_state` / :meth:`load_member_state` convert, in
    ``nn.Sequential`` naming).

    Each member's block of a parameter is padded (zeros the network never reads, whose gradient
    and so Adam step are zero) to a whole number of :data:`MEMBER_ALIGN` floats: PyTorch's fused
    Adam runs a tensor's whole vectors in one code path and the rest in another that rounds
    differently, so an unpadded ``(M, 1, 2)`` bias would put a member's elements in one path or
    the other depending on ``M``, and a seed's training on how many seeds share its stack
    (measured: the first difference after 11-104 updates). Padded, every member takes the same
    path whatever ``M``. Only the last layers' biases (and unusual widths) need it.

    ``dtype=torch.bfloat16`` runs the network in bfloat16 on bfloat16 copies of the float32
    parameters (cast once per layer and call; gradients flow back to the float32 masters, which
    Adam updates in float32): products, activations and the norms' affine maps in bfloat16, the
    norms' statistics accumulated in float32; the output is float32.
    """

    def __init__(self, members: int, sizes: tuple[int, ...], layer_norm: bool = False) -> None:
        super().__init__()
        self.members, self.sizes = int(members), tuple(int(s) for s in sizes)
        self.layer_norm = bool(layer_norm)
        shapes = zip(sizes[:-1], sizes[1:], strict=False)
        self.weights = nn.ParameterList(
            [nn.Parameter(torch.zeros(self.members, i, _padded(i, o))) for i, o in shapes])
        self.biases = nn.ParameterList(
            [nn.Parameter(torch.zeros(self.members, 1, _padded(1, o))) for o in sizes[1:]])
        hidden = sizes[1:-1] if self.layer_norm else ()
        self.norm_gains = nn.ParameterList(
            [nn.Parameter(torch.ones(self.members, 1, _padded(1, o))) for o in hidden])
        self.norm_biases = nn.ParameterList(
            [nn.Parameter(torch.zeros(self.members, 1, _padded(1, o))) for o in hidden])

    def forward(self, x: torch.Tensor, dtype: torch.dtype = torch.float32,
                members: slice = slice(None)) -> torch.Tensor:
        """``x`` ``(m, B, in)`` through members ``members`` (default all ``M``) -> ``(m, B, out)``,
        float32."""
        # indexing even with the full slice records a slice op whose backward allocates and fills
        # a zero tensor of every weight's size: ~8 % of an update
        every_member = members == slice(None)

        def own(p: torch.Tensor, width: int) -> torch.Tensor:
            """The members' slice of a parameter without its padding, in the products' dtype."""
            p = p if every_member else p[members]
            p = p if p.shape[-1] == width else p[..., :width]
            return p if p.dtype == dtype else p.to(dtype)

        # in a low precision the activations stay in it from layer to layer (the layer norm
        # accumulates in float32 and returns the input's dtype): casting them to float32 and back
        # at every layer cost ~15 % of an update, and the next product rounds them anyway
        h = x.to(dtype)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            width = self.sizes[i + 1]
            h = torch.baddbmm(own(b, width), h, own(w, width))
            if i < last:
                if self.layer_norm:
                    h = nn.functional.layer_norm(h, h.shape[-1:], eps=1e-5)
                    h = torch.addcmul(own(self.norm_biases[i], width), h,
                                      own(self.norm_gains[i], width))
                h = torch.relu_(h)  # in place: the backward of the op before needs not its output
        return h.float()

    def _layer_names(self, i: int) -> tuple[str, str | None]:
        """``nn.Sequential`` indices of hidden layer ``i``'s linear map and of its norm (or None)."""
        if self.layer_norm:
            return str(3 * i), (str(3 * i + 1) if i < len(self.weights) - 1 else None)
        return str(2 * i), None

    def member_state(self, m: int) -> dict[str, torch.Tensor]:
        """Member ``m`` as an ``nn.Sequential`` state dict (``"0.weight"``, ``"0.bias"``, ...)."""
        state = {}
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            linear, norm = self._layer_names(i)
            o = self.sizes[i + 1]
            state[f"{linear}.weight"] = w[m, :, :o].detach().T.contiguous().clone()
            state[f"{linear}.bias"] = b[m, 0, :o].detach().clone()
            if norm is not None:
                state[f"{norm}.weight"] = self.norm_gains[i][m, 0, :o].detach().clone()
                state[f"{norm}.bias"] = self.norm_biases[i][m, 0, :o].detach().clone()
        return state

    @torch.no_grad()
    def load_member_state(self, m: int, state: dict[str, torch.Tensor]) -> None:
        """Inverse of :meth:`member_state`."""
        expected = set(self.member_state(m))
        if set(state) != expected:
            raise ValueError(f"the state's layers {sorted(state)} are not this network's "
                             f"{sorted(expected)} (hidden sizes or layer normalisation differ)")
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            linear, norm = self._layer_names(i)
            weight, bias = state[f"{linear}.weight"], state[f"{linear}.bias"]
            o = self.sizes[i + 1]
            if tuple(weight.shape) != (o, w.shape[1]):
                raise ValueError(f"layer {i}: weight of shape {tuple(weight.shape)}, expected "
                                 f"{(o, w.shape[1])} (hidden sizes differ)")
            w[m, :, :o].copy_(weight.T)
            b[m, 0, :o].copy_(bias)
            if norm is not None:
                self.norm_gains[i][m, 0, :o].copy_(state[f"{norm}.weight"])
                self.norm_biases[i][m, 0, :o].copy_(state[f"{norm}.bias"])


def prefixed(state: dict[str, torch.Tensor], prefix: str) -> dict[str, torch.Tensor]:
    """``state`` with ``prefix`` before every key (``"0.weight"`` -> ``"q1_net.0.weight"``)."""
    return {f"{prefix}{k}": v for k, v in state.items()}


def unprefixed(state: dict[str, torch.Tensor], prefix: str) -> dict[str, torch.Tensor]:
    """The entries of ``state`` under ``prefix``, without it (inverse of :func:`prefixed`)."""
    return {k[len(prefix):]: v for k, v in state.items() if k.startswith(prefix)}


def member_adam_state(optimizer: torch.optim.Adam, net: StackedMLP, members: list[int],
                     prefixes: list[str]) -> dict[str, Any]:
    """Adam moments of members ``members`` of ``net`` in plain-module naming (member ``m`` under
    ``prefixes[i]``), and the step count (Adam's moments are elementwise, so a member's slice is
    exactly the moments it would have trained alone)."""
    params = list(net.parameters())
    state = [optimizer.state.get(p, {}) for p in params]
    out: dict[str, Any] = {"step": int(state[0]["step"]) if state[0] else 0}
    for name in ("exp_avg", "exp_avg_sq"):
        shadow = StackedMLP(net.members, net.sizes, net.layer_norm)
        if state[0]:
            with torch.no_grad():
                for p, s in zip(shadow.parameters(), state, strict=True):
                    p.copy_(s[name])
        out[name] = {}
        for m, prefix in zip(members, prefixes, strict=True):
            out[name].update(prefixed(shadow.member_state(m), prefix))
    return out


def load_member_adam_state(optimizer: torch.optim.Adam, net: StackedMLP, members: list[int],
                          prefixes: list[str], state: dict[str, Any]) -> None:
    """Inverse of :func:`member_adam_state`: the other members' moments are kept."""
    params = list(net.parameters())
    if not optimizer.state.get(params[0]):
        for p in params:
            optimizer.state[p] = {"step": torch.tensor(0.0), "exp_avg": torch.zeros_like(p),
                                  "exp_avg_sq": torch.zeros_like(p)}
    for name in ("exp_avg", "exp_avg_sq"):
        shadow = StackedMLP(net.members, net.sizes, net.layer_norm)
        with torch.no_grad():
            for p, q in zip(shadow.parameters(), params, strict=True):
                p.copy_(optimizer.state[q][name])
            for m, prefix in zip(members, prefixes, strict=True):
                shadow.load_member_state(m, unprefixed(state[name], prefix))
            for p, q in zip(shadow.parameters(), params, strict=True):
                optimizer.state[q][name].copy_(p)
    for q in params:
        optimizer.state[q]["step"] = torch.tensor(float(state["step"]))
