"""Sphinx configuration (built with -W: warnings are errors)."""

project = "elastica-magnetic"
author = "elastica-magnetic developers"
copyright = "2026, elastica-magnetic developers"
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "validation/*.md",  # included by validation.md
                    "examples/*/report.md",  # a loop's report, kept as it was written
                    "examples/**/MODEL_CARD.md"]  # a policy's card beside an example, read as a file
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
napoleon_numpy_docstring = True
napoleon_google_docstring = True  # rl/ uses Google style (Args:), elastica_magnetic/ numpy style
nitpicky = False
html_theme = "alabaster"
napoleon_use_ivar = True
