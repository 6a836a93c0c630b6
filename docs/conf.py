"""Sphinx configuration of the documentation (the Markdown guides with MyST, and the API
reference): ``python -m sphinx -W -b html docs docs/_build/html``."""
import pathlib
import sys

import fasttrack

sys.path.insert(0, str(pathlib.Path(__file__).parent))  # for _gallery

project = "fasttrack"
release = version = fasttrack.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon", "myst_parser",
              "sphinx_gallery.gen_gallery"]
myst_heading_anchors = 3
napoleon_google_docstring = False
napoleon_numpy_docstring = True
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
exclude_patterns = ["_build", "examples"]
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "tutorials",
    "filename_pattern": r"\.py$",  # run every tutorial
    "reset_argv": "_gallery.plot_folder",
    "image_scrapers": ("_gallery.png_scraper",),
    "download_all_examples": False,
}
html_theme = "alabaster"
nitpicky = False


def _public_bases(app, name, obj, options, bases):
    """Show a class's public ancestors in place of private helper bases."""
    def public(base):
        if not base.__name__.startswith("_"):
            return [base]
        return [b for parent in base.__bases__ for b in public(parent)]
    bases[:] = [b for base in list(bases) for b in public(base)]


def setup(app):
    app.connect("autodoc-process-bases", _public_bases)
