"""Sphinx configuration of the API reference: ``python -m sphinx -W -b html docs docs/_build``."""
import fasttrack

project = "fasttrack"
release = version = fasttrack.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
napoleon_google_docstring = False
napoleon_numpy_docstring = True
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
exclude_patterns = ["_build", "examples", "*.md"]
html_theme = "alabaster"
nitpicky = False
