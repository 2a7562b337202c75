"""The served web viewer loads in headless Chromium and draws something (regenerates nothing in docs/)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from nodes.viz.screenshot import find_browser

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
@pytest.mark.skipif(find_browser() is None, reason="no Chromium installed (Debian: apt-get install chromium)")
def test_served_web_viewer_renders_in_headless_chromium(tmp_path: Path) -> None:
    out = tmp_path / "viz.png"
    result = subprocess.run([sys.executable, "-m", "nodes.viz.screenshot", "--out", str(out), "--settle", "3",
                             "--render", "15"], cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert result.returncode == 0, result.stdout + result.stderr
    image = pytest.importorskip("PIL.Image").open(out).convert("RGB")
    assert image.size == (1400, 800)
    left = image.crop((0, 40, 840, 770)).getcolors(maxcolors=1 << 20)  # the 3-D view
    # The ground (our grey box, shaded), covering a good part of the view: the scene was drawn.
    ground = sum(n for n, (r, g, b) in left if 60 <= r <= 120 and 0 <= g - r <= 12 and 0 <= b - r <= 20)
    assert ground > 50_000, f"no ground in the 3-D view ({ground} grey pixels): viewer not drawn"
    # The robot's torso blue (URDF material 'blue', shaded) is somewhere in the 3-D view on the left.
    bluish = sum(n for n, (r, g, b) in left if b > 120 and b > r + 60 and b > g + 30)
    assert bluish > 2000, f"no robot torso in the 3-D view ({bluish} blue pixels)"
