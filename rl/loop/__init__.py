"""``msr loop``: the whole path for a new robot in one resumable command (check, yardstick, train,
generate, robustness, refine, robustness again, firmware), each step a library call writing its own
subfolder of the loop's folder, recorded in ``loop.json`` and reported in ``report.md`` /
``report.html`` after every step."""
