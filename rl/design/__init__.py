"""``msr design``: search magnetizations a lab can make (CMA-ES over segments), each candidate
judged by the rotating-field yardstick (or its worst case over fabrication errors) in batched
simulations; see :mod:`elastica_magnetic_rl.design.run`."""
