"""Figures are written under a temporary name and renamed into place: a run killed while it
draws leaves the previous figure whole (or the new one), never a truncated file."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from thinfilm.plots import partial_path, plt, save_figure

PNG = b"\x89PNG\r\n\x1a\n"


def _figure():
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    return fig


def test_a_figure_is_written_whole_and_no_partial_file_is_left(tmp_path):
    path = save_figure(_figure(), tmp_path / "energy.png")
    assert path.read_bytes()[:8] == PNG
    assert sorted(p.name for p in tmp_path.iterdir()) == ["energy.png"]
    assert partial_path(path).name == ".energy.partial.png"


def test_a_write_cut_short_keeps_the_previous_figure(tmp_path, monkeypatch):
    path = save_figure(_figure(), tmp_path / "alpha.png")
    before = path.read_bytes()
    fig = _figure()

    def cut_short(target, **kwargs):  # half a file written, then the process "dies"
        with open(target, "wb") as f:
            f.write(before[: len(before) // 2])
        raise KeyboardInterrupt

    monkeypatch.setattr(fig, "savefig", cut_short)
    with pytest.raises(KeyboardInterrupt):
        save_figure(fig, path)
    assert path.read_bytes() == before


def test_kill_9_while_drawing_never_leaves_a_truncated_figure(tmp_path):
    # a process redrawing one large figure in a loop, killed at 6 moments spread over its
    # writes: the figure on disk is always a whole PNG (its IEND chunk closes it)
    script = textwrap.dedent(f"""
        import numpy as np
        from thinfilm.plots import plt, save_figure
        fig, ax = plt.subplots(figsize=(8, 8))
        ax.imshow(np.random.default_rng(0).random((600, 600)))
        save_figure(fig, {str(tmp_path / 'alpha.png')!r})
        print("ready", flush=True)
        while True:
            save_figure(fig, {str(tmp_path / 'alpha.png')!r}, dpi=150)
    """)
    for k in range(6):
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, cwd=os.getcwd())
        assert proc.stdout.readline().strip() == b"ready"
        time.sleep(0.05 + 0.17 * k)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        data = (tmp_path / "alpha.png").read_bytes()
        assert data[:8] == PNG and data[-8:-4] == b"IEND", k
