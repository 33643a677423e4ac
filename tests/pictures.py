"""What a drawn picture must hold: a PNG of the expected size with something drawn on it.

Checks the file's content rather than its existence: it decodes as a PNG (matplotlib's
reader), it is at least ``min_pixels`` wide and high, and a fraction ``min_inked`` of its pixels
differ from its background (the colour of its top-left corner) in more than ``min_colours``
distinct colours, so that an empty axes frame or a blank canvas fails.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def assert_drawn(path: Path, *, min_pixels: int = 200, min_inked: float = 0.02,
                 min_colours: int = 16) -> np.ndarray:
    """Assert that ``path`` is a PNG with a drawing on it; return its pixels (H, W, channels)."""
    from matplotlib import image

    path = Path(path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    pixels = image.imread(path)
    height, width = pixels.shape[:2]
    assert min(height, width) >= min_pixels, f"{path.name}: {width} x {height} pixels"
    rgb = np.round(pixels[..., :3] * 255).astype(np.int64)
    inked = np.any(rgb != rgb[0, 0], axis=-1)
    assert inked.mean() >= min_inked, f"{path.name}: {inked.mean():.1%} of the pixels drawn"
    codes = (rgb[inked] * np.array([65536, 256, 1])).sum(axis=-1)
    assert np.unique(codes).size >= min_colours, f"{path.name}: {np.unique(codes).size} colours"
    return pixels


def movie_frames(path: Path) -> int:
    """Number of frames of an MP4 as ffmpeg decodes it (imageio-ffmpeg)."""
    import imageio_ffmpeg

    return imageio_ffmpeg.count_frames_and_secs(str(path))[0]


def assert_figures(paths) -> None:
    """Every figure file drawn: PNGs by :func:`assert_drawn`, PDFs by their header and pages."""
    paths = list(paths)
    assert paths, "no figure written"
    for path in paths:
        path = Path(path)
        if path.suffix == ".png":
            assert_drawn(path)
        elif path.suffix == ".pdf":
            data = path.read_bytes()
            assert data[:5] == b"%PDF-" and b"/Type /Page" in data, f"{path.name}: not a PDF page"
        else:
            assert path.read_text().strip(), f"{path.name} is empty"
