"""Regenerate the documentation figures that need no experiment run.

    python docs/make_figures.py      # writes docs/figures/shapes.png
"""

from pathlib import Path

from dexpush import Shape
from dexpush.viz import plot_shapes

if __name__ == "__main__":
    out = Path(__file__).parent / "figures" / "shapes.png"
    plot_shapes([Shape.rectangle(), Shape.tee(), Shape.ellipse()], path=out)
    print(out)
