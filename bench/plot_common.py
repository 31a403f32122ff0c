"""Helpers shared by bench/plot.py and bench/plot_loss.py.

Importing this module selects matplotlib's headless Agg backend; take `plt`
from here. The scripts put their own folder first on sys.path before they
import this module, so they run from any working directory.
"""
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402,F401


def load(path):
    """The JSON object in the file at path."""
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def write_text(path, text):
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def output_dir(out, json_path):
    """out, or else the folder of json_path; created when missing."""
    out = out or os.path.dirname(os.path.abspath(json_path))
    os.makedirs(out, exist_ok=True)
    return out


def save_figure(fig, path, dpi, **layout):
    """tight_layout(**layout), write the PNG at path, close the figure."""
    fig.tight_layout(**layout)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def style_axes(ax, xlabel=None, ylabel=None, title=None, legend_size=8, legend_cols=1, **grid):
    """Labels and title where given, a light grid (grid: extra grid() arguments), a legend."""
    if xlabel is not None:
        ax.set_xlabel(xlabel)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    if title is not None:
        ax.set_title(title)
    ax.grid(True, alpha=0.3, **grid)
    ax.legend(fontsize=legend_size, ncol=legend_cols)


def update_doc(doc_path, begin, end, out, render):
    """Replaces the text between the markers begin and end in the Markdown file
    doc_path with render(prefix), where prefix leads from the file's folder to
    out ("" or "rel/path/"). Returns False, leaving the file alone, when the
    markers are not there in that order."""
    with open(doc_path, encoding="utf-8") as f:
        doc = f.read()
    i, j = doc.find(begin), doc.find(end)
    if i < 0 or j <= i:
        return False
    rel = os.path.relpath(out, os.path.dirname(os.path.abspath(doc_path)))
    md = render("" if rel == "." else rel + "/")
    write_text(doc_path, doc[: i + len(begin)] + "\n" + md + "\n" + doc[j:])
    return True
