"""Looking at runs: figures (``figures``), the networks' health (``diagnostics``, ``msr diagnose``) and
the learning benchmarks (``bench``, ``msr bench``)."""
