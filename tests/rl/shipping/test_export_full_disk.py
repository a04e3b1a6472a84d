"""``msr policy export`` on a full disk (issue 48, "Tracebacks and vague messages", item 2): torch's C++
writer, given a path, aborted the process (``terminate called after throwing an instance of
'c10::Error'``, ``unexpected pos``); the actor is now saved to memory and written with Python's
I/O, so the full disk is one named error and the earlier export stays byte for byte. The disk
fills in a real ``msr`` process (``tests/faults.py``: writes to the file fail with ENOSPC)."""

from __future__ import annotations

import os

import pytest
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from faults import Fault

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork is POSIX")


def snapshot(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("name, temporary", [
    ("policy.ts.pt", r"\.policy\.ts\.tmp\d+\.pt$"),  # TorchScript (torch.jit.save)
    ("policy.pt2", r"\.policy\.tmp\d+\.pt2$"),  # torch.export.save
])
def test_export_on_a_full_disk_is_a_named_error(fault_server, tmp_path, name, temporary):
    from elastica_magnetic.results import result_folder

    out = tmp_path / "export"
    with result_folder(out, kind="export", subject="case m1-4mT") as folder:  # an earlier export
        for file in ("policy.ts.pt", "policy.pt2", "policy.json"):
            (folder.path / file).write_bytes(f"earlier {file}\n".encode() * 100)
    earlier = snapshot(out)

    done = fault_server.run(["policy", "export", POLICIES_DIR / "m1-4mT", "--out", out, "--force"],
                            Fault("enospc", r"/\.export\.msr-new-[^/]*/" + temporary, after=100))
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        f"msr policy export: error: {out / name}: cannot write: No space left on device; {out} is left as "
        "it was")
    assert snapshot(out) == earlier
    assert sorted(p.name for p in out.parent.iterdir()) == ["export"]  # no temporary left beside


@pytest.mark.filterwarnings("ignore:`torch.jit.load` is deprecated:DeprecationWarning")
def test_the_files_written_from_memory_load_with_plain_torch(fault_server, tmp_path):
    import torch

    out = tmp_path / "export"
    done = fault_server.run(["policy", "export", POLICIES_DIR / "m1-4mT", "--out", out])
    assert done.returncode == 0, done.stderr
    assert "max_abs_diff: 0" in done.stdout  # the reloaded files act as the actor does
    actions = torch.jit.load(str(out / "policy.ts.pt"))(torch.zeros(3, 260))
    assert actions.shape == (3, 2)
    assert torch.equal(torch.export.load(str(out / "policy.pt2")).module()(torch.zeros(3, 260)),
                       actions)


def test_ship_on_a_full_disk_is_a_named_error(fault_server, trained, tmp_path):
    """``msr policy ship`` saved the weights with torch's own file writer too: the same abort."""
    dest = tmp_path / "policies"
    done = fault_server.run(["policy", "ship", trained / "m1-4mT" / "seed0", "--name", "mine", "--out", dest,
                             "--no-measure", "--checkpoint", "final"],
                            Fault("enospc", r"\.actor\.tmp\d+\.pt$", after=100))
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr and "terminate called" not in done.stderr
    assert "actor.pt: cannot write: No space left on device" in done.stderr, done.stderr
    assert not (dest / "mine" / "actor.pt").exists()
