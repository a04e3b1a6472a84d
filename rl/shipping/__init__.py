"""From trained runs to shipped policies: policy files and how a policy argument is loaded
(``policy_files``), rolling a policy out and judging a case's seeds (``policy_runs``), generate, ship
and export (``pipeline``), every seed as a policy folder (``seed_export``) and its report
(``seed_report``), the model card, the checks of the shipped policies (``shipped``) and the
hand-designed baseline (``baselines``). The shipped policies themselves are data in ``rl/policies/``."""
