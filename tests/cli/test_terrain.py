"""The terrain CLI: real runs on small grids, and every bad input -> one line, exit 2, no file."""

import json

import numpy as np
import pytest
from PIL import Image

from offroadbench.cli import main

SMALL = ["--set", "grid.rows=81", "--set", "grid.cols=81"]


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_terrains_lists_presets(capsys):
    code, out, _ = run(capsys, "terrains")
    assert code == 0
    for d in ("2.3", "2.45", "2.6"):
        assert f"paper-d{d}" in out
    assert "multifractal" in out


def test_generate_then_analyze(tmp_path, capsys):
    png = tmp_path / "t.png"
    code, out, err = run(capsys, "generate", "paper-d2.6", "--seed", "3", "-o", str(png), *SMALL)
    assert code == 0, err
    side = json.loads((tmp_path / "t.json").read_text())
    assert side["seed"] == 3 and side["recipe_name"] == "paper-d2.6" and side["rows"] == 81
    assert side["recipe"]["layers"]["base"]["D_high"] == 2.6
    code, out, err = run(capsys, "analyze", str(png), "--plot", str(tmp_path / "fig.png"), "--border-m", "0.5")
    assert code == 0, err
    assert "low" in out and "semi" in out and "high" in out
    with Image.open(tmp_path / "fig.png") as img:
        assert img.size[0] > 500


def test_same_seed_same_png_bytes(tmp_path, capsys):
    a, b, c = (tmp_path / n for n in ("a.png", "b.png", "c.png"))
    for p, seed in ((a, "4"), (b, "4"), (c, "5")):
        assert run(capsys, "generate", "paper-d2.45", "--seed", seed, "-o", str(p), *SMALL)[0] == 0
    qa, qb, qc = (np.asarray(Image.open(p)) for p in (a, b, c))
    assert np.array_equal(qa, qb) and not np.array_equal(qa, qc)


def test_roughness_study_small(tmp_path, capsys):
    code, out, err = run(
        capsys, "roughness-study", "--dims", "2.3", "2.6", "--terrains", "2", "--border-m", "0.5", "--out", str(tmp_path / "rs"), *SMALL
    )
    assert code == 0, err
    assert "median_low_pct" in out
    assert (tmp_path / "rs" / "roughness_study.png").is_file()
    assert (tmp_path / "rs" / "roughness_summary.csv").is_file()


@pytest.mark.parametrize(
    "argv, match",
    [
        (["generate", "paper-d2.45", "--set", "layers.base.D_high=3.5"], "D_high = 3.5 is out of range; allowed: (2, 3)"),
        (["generate", "paper-d2.45", "--set", "layers.base.D_high=2.0"], "D_high = 2.0 is out of range"),
        (["generate", "paper-d2.45", "--set", "layers.base.wm.gamma=1.0"], "layers.base.wm.gamma = 1.0 is out of range"),
        (["generate", "paper-d2.45", "--set", "layers.base.M=[16, 0, 64]"], "M[1] = 0 is out of range"),
        (["generate", "paper-d2.45", "--set", "grid.rows=0"], "grid.rows = 0"),
        (["generate", "no-such-preset"], "unknown terrain preset 'no-such-preset'"),
        (["generate", "paper-d2.45", "--set", "layers.base.Dhigh=2.5"], "unknown key(s) layers.base.Dhigh"),
        (["generate", "paper-d2.45", "--set", "novalue"], "expected KEY=VALUE"),
    ],
)
def test_bad_input_one_line_exit_2_no_file(tmp_path, capsys, argv, match):
    out_png = tmp_path / "o.png"
    code, out, err = run(capsys, *argv, "-o", str(out_png))
    assert code == 2
    assert match in err
    assert err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_output_parents_are_created_but_unwritable_places_refused(tmp_path, capsys):
    code, _, err = run(capsys, "generate", "paper-d2.45", "-o", str(tmp_path / "new" / "dir" / "o.png"), *SMALL)
    assert code == 0, err
    assert (tmp_path / "new" / "dir" / "o.json").is_file()
    (tmp_path / "file").write_text("x")
    code, _, err = run(capsys, "generate", "paper-d2.45", "-o", str(tmp_path / "file" / "o.png"), *SMALL)
    assert code == 2 and "is a file, not a directory" in err and err.count("\n") == 1
    code, _, err = run(capsys, "generate", "paper-d2.45", "-o", "/proc/offroadbench/o.png", *SMALL)
    assert code == 2 and "cannot write into /proc" in err and err.count("\n") == 1
    code, _, err = run(capsys, "generate", "paper-d2.45", "-o", str(tmp_path), *SMALL)
    assert code == 2 and err.count("\n") == 1


def test_nan_height_and_8_bit_png_refused(tmp_path, capsys):
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(tmp_path / "g8.png")
    code, _, err = run(capsys, "analyze", str(tmp_path / "g8.png"))
    assert code == 2 and "8-bit grayscale PNG; a heightmap must be 16-bit" in err
    np.save(tmp_path / "nan.npy", np.array([[0, 1, 2], [0, np.nan, 2], [0, 1, 2]], float))
    from offroadbench import Heightmap, InputError

    with pytest.raises(InputError, match="NaN"):
        Heightmap(np.load(tmp_path / "nan.npy"), 0.05)


def test_bad_seed_and_counts_exit_2(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["generate", "paper-d2.45", "--seed", "-3", "-o", "x.png"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["roughness-study", "--terrains", "0"])
    assert exc.value.code == 2


def test_analyze_warns_about_a_spire_and_clips_on_request(tmp_path, capsys, caplog):
    import logging

    from offroadbench import Heightmap
    from offroadbench.io.png16 import write_png16

    y, x = np.mgrid[0:120, 0:120] * 0.05
    z = 0.6 + 0.2 * np.sin(3 * x) * np.cos(2 * y)
    z[0, 0] = 3.84  # one corner sample holds most of the relief, as on the paper presets
    write_png16(Heightmap(z, 0.05), tmp_path / "spire.png")
    with caplog.at_level(logging.WARNING, logger="offroadbench.cli.terrain"):
        code, out, err = run(capsys, "analyze", str(tmp_path / "spire.png"), "--border-m", "0.5")
    assert code == 0, err
    assert "top 0.1 % of samples span" in caplog.text and "relief 3.440 m" in out
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="offroadbench.cli.terrain"):
        code, out, err = run(capsys, "analyze", str(tmp_path / "spire.png"), "--border-m", "0.5", "--clip-percentile", "0.1")
    assert code == 0, err
    assert "span" not in caplog.text and "relief 0.39" in out
    code, _, err = run(capsys, "analyze", str(tmp_path / "spire.png"), "--clip-percentile", "-1")
    assert code == 2 and "--clip-percentile -1.0 is out of range" in err
