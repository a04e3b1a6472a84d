"""The files of a training run: the run folder's names and the checkpoint format (torch and numpy only;
no other module of this package). Layer 0: every other subpackage may read or write run files."""
