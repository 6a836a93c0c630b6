"""Sphinx-gallery hooks of the documentation build: each tutorial is run with a scratch
folder as its command-line argument, and the PNGs it writes there become its figures (the
plots are pyplot-free, so the gallery's matplotlib scraper does not see them)."""
import pathlib
import shutil
import tempfile

from sphinx_gallery.scrapers import figure_rst

_ROOT = pathlib.Path(tempfile.gettempdir()) / "fasttrack-gallery"


def _folder(src_file):
    return _ROOT / pathlib.Path(src_file).stem


def plot_folder(gallery_conf, script_vars):
    """The command line of a tutorial: a fresh folder for its plots."""
    folder = _folder(script_vars["src_file"])
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    return [str(folder)]


def png_scraper(block, block_vars, gallery_conf):
    """The reST of the PNGs the tutorial has written since the last code block."""
    folder = _folder(block_vars["src_file"])
    shown = block_vars.setdefault("fasttrack_shown", set())
    new = sorted(p for p in folder.glob("*.png") if p not in shown)
    shown.update(new)
    targets = []
    for png, target in zip(new, block_vars["image_path_iterator"]):
        shutil.copyfile(png, target)
        targets.append(target)
    return figure_rst(targets, gallery_conf["src_dir"])
