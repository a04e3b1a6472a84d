"""From simulation to the robot you built: varied robots (:mod:`.variations`), the robustness of
a waveform or policy to them (:mod:`.robustness`, ``msr real robustness``), measured trajectories
(:mod:`.tracking`) and the identification of spec values from one (:mod:`.identify`,
``msr real identify``)."""
