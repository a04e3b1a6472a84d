"""The files of a training run, the bottom layer (torch and numpy only; no other subpackage):
``rundir`` (:class:`~elastica_magnetic_rl.runfiles.rundir.RunDir` and
:class:`~elastica_magnetic_rl.runfiles.rundir.CaseDir`: the one home for the names of a run's and a
case's files), ``checkpoint`` (the checkpoint format: writer, reader, the replay file's rows) and
``provenance`` (versions and machine fingerprint recorded with runs and policies)."""
