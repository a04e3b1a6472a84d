"""Many seeds and cases: ``msr train`` / ``msr refine`` (``training``), groups of seeds in worker
processes or Ray tasks (``backends``), one summary per case."""
