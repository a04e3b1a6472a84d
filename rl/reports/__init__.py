"""Looking at runs: figures (``figures``), the networks' health (``diagnostics``, ``msr policy diagnose``) and
the learning benchmarks (``bench``, ``msr bench``)."""
