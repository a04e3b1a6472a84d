"""From trained runs to shipped policies: policy files and how a policy argument is loaded
(``policy_files``), rolling a policy out and judging a case's seeds (``policy_runs``), ``generate``
(``msr policy generate``, ``baseline``, ``demo``), ``ship`` (``msr policy ship``, ``notes``),
``export`` (``msr policy export``), every seed as a policy folder (``seed_export``) and its report
(``seed_report``), the model card, the checks of the shipped policies (``shipped``) and the
search of the hand-designed yardstick's best field (``baseline_sweep``; the yardsticks themselves are
:mod:`elastica_magnetic_rl.envs.yardsticks`). The shipped policies themselves are data in
``rl/policies/``.

The workflow of the paper's "Miscellaneous training tips": train a case's seeds
(:func:`elastica_magnetic_rl.sweep.training.train_case`), refine the best in the accurate physics
(:func:`elastica_magnetic_rl.sweep.refine.refine`), then generate its waveform, ship it into
``rl/policies/<name>/`` and export it to run without this package.
"""
