"""A contact sheet: every figure and animation under a folder in one image, each thumbnail with its
path, so a reviewer sees a demo's whole output at a glance (an animation by its middle frame, with
its frame count). tests/test_demo_figures.py writes one of make demo's figures."""

from __future__ import annotations

from pathlib import Path

from ..atomic import replacing
from .results import natural_key


def pictures_in(root: Path) -> list[Path]:
    """The PNG and GIF files under ``root`` in the results page's order (numbers as numbers)."""
    root = Path(root)
    found = [p for p in root.rglob("*") if p.suffix.lower() in (".png", ".gif") and p.name != "contact_sheet.png"]
    return sorted(found, key=lambda p: natural_key(p.relative_to(root)))


def _thumbnail(path: Path):
    """The picture as an RGB array, and a note (an animation's frame count)."""
    from PIL import Image
    import numpy as np

    with Image.open(path) as image:
        frames = getattr(image, "n_frames", 1)
        if frames > 1:
            image.seek(frames // 2)
        rgb = np.asarray(image.convert("RGB"))
    return rgb, (f"GIF, {frames} frames (middle one)" if frames > 1 else f"{rgb.shape[1]} x {rgb.shape[0]} px")


def write_contact_sheet(root: Path, out: Path | None = None, columns: int = 6) -> Path:
    """Draw every picture under ``root`` on one sheet (``root/contact_sheet.png`` by default)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    root = Path(root)
    pictures = pictures_in(root)
    if not pictures:
        raise FileNotFoundError(f"no PNG or GIF under {root}")
    out = Path(out) if out else root / "contact_sheet.png"
    rows = -(-len(pictures) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.9 * rows), squeeze=False)
    for ax in axes.flat:
        ax.set_axis_off()
    for ax, path in zip(axes.flat, pictures):
        rgb, note = _thumbnail(path)
        ax.imshow(rgb, interpolation="antialiased")
        ax.set_title(f"{path.relative_to(root)}\n{note}", fontsize=7)
    fig.suptitle(f"{len(pictures)} figures and animations under {root.name or root}", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_size_inches()[1]))        # the title's band
    with replacing(out) as temporary:
        fig.savefig(temporary, dpi=110, format="png")
    plt.close(fig)
    return out
