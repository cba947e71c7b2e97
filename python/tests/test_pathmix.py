"""The Python package against the command line it wraps: the same run gives
the same bits, and a bad scene the same message.

The command line is found at $PATHMIX_BIN, else in the cargo target folder
($CARGO_TARGET_DIR or target/, release build); without it the tests that
compare with it fail, saying so."""

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import pathmix

ROOT = Path(__file__).resolve().parents[2]
CORNELL = ROOT / "scenes" / "cornell.toml"
# Small enough for a software rasterizer's few cores.
SIZE = {"width": 32, "height": 24}


def cli() -> Path:
    candidates = [os.environ.get("PATHMIX_BIN")]
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    candidates += [str(target / "release" / "pathmix"), shutil.which("pathmix")]
    for candidate in candidates:
        if candidate and Path(candidate).is_file():
            return Path(candidate)
    pytest.fail(
        "no pathmix command line: build it (`cargo build --release`) or set PATHMIX_BIN"
    )


def cli_render(tmp_path: Path, *flags: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(cli()), "render", str(CORNELL), "-q", "-o", str(tmp_path / "out.png"), *flags],
        capture_output=True,
        text=True,
        check=True,
    )


@pytest.fixture(scope="module")
def scene() -> pathmix.Scene:
    return pathmix.load(CORNELL)


def test_render_is_a_float32_image(scene):
    image = pathmix.render(scene, spp=4, **SIZE)
    assert image.shape == (24, 32, 3)
    assert image.dtype == np.float32
    assert np.isfinite(image).all()
    assert image.mean() > 0.0


def test_render_matches_the_command_lines_exr_bit_for_bit(scene, tmp_path):
    exr = tmp_path / "out.exr"
    cli_render(tmp_path, "--spp", "8", "--width", "32", "--height", "24", "--seed", "7",
               "--exr", str(exr))
    image = pathmix.render(scene, spp=8, seed=7, **SIZE)
    expected = pathmix.read_exr(exr)
    assert image.shape == expected.shape
    assert np.array_equal(image, expected)
    # Another seed is another image: the comparison can fail.
    assert not np.array_equal(pathmix.render(scene, spp=8, seed=8, **SIZE), expected)


def test_error_map_matches_the_command_lines_variance_output(scene, tmp_path):
    exr, variance = tmp_path / "out.exr", tmp_path / "error.exr"
    cli_render(tmp_path, "--spp", "8", "--width", "32", "--height", "24", "--strategy",
               "nee-mis", "--exr", str(exr), "--variance", str(variance))
    image, error = pathmix.render(scene, spp=8, strategy="nee-mis", return_error=True, **SIZE)
    assert error.shape == image.shape and error.dtype == np.float32
    assert np.array_equal(image, pathmix.read_exr(exr))
    assert np.array_equal(error, pathmix.read_exr(variance))
    assert (error >= 0).all() and error.mean() > 0.0


@pytest.mark.parametrize("scene_file, setting, value", [
    ("furnace.toml", "light_selection", "uniform"),  # 6 lights: spatial by default
    ("sky.toml", "reconstruction", "importance"),  # Gaussian filter: splatted by default
    ("cornell.toml", "rr_depth", "off"),  # nee-mis: roulette from 5 by default
    ("cornell.toml", "rr_depth", 1),
])
def test_trade_settings_match_the_command_line(tmp_path, scene_file, setting, value):
    path, exr = ROOT / "scenes" / scene_file, tmp_path / "out.exr"
    flags = ["--spp", "8", "--seed", "3", "--strategy", "nee-mis", "--width", "32",
             "--height", "24"]
    subprocess.run([str(cli()), "render", str(path), "-q", *flags,
                    "--" + setting.replace("_", "-"), str(value), "--exr", str(exr),
                    "-o", str(tmp_path / "out.png")], capture_output=True, check=True)
    loaded = pathmix.load(path)
    run = {"spp": 8, "seed": 3, "strategy": "nee-mis", **SIZE}
    image = pathmix.render(loaded, **run, **{setting: value})
    assert np.array_equal(image, pathmix.read_exr(exr))
    # The default is the other choice and another image: the argument is not ignored.
    assert not np.array_equal(pathmix.render(loaded, **run), image)


def test_aovs_come_beside_the_same_image(scene):
    image, aovs = pathmix.render(scene, spp=4, seed=3, aovs="albedo,dd:depth", **SIZE)
    assert np.array_equal(image, pathmix.render(scene, spp=4, seed=3, **SIZE))
    assert list(aovs) == ["albedo", "dd"]
    assert aovs["albedo"].shape == (24, 32, 3) and aovs["dd"].shape == (24, 32, 1)
    assert aovs["albedo"].dtype == np.float32
    # The walls are their materials' colours; rays that miss the box are 0.
    assert (aovs["albedo"] >= 0).all() and (aovs["albedo"] <= 1).all()
    assert aovs["albedo"].max() == np.float32(0.73)
    assert (aovs["dd"] >= 0).all() and aovs["dd"][12, 16, 0] > 0
    with pytest.raises(ValueError, match="prim_index"):
        pathmix.render(scene, spp=1, aovs="p:prim_index", **SIZE)
    with pytest.raises(ValueError, match="no textures"):
        pathmix.render(scene, spp=1, aovs="uv", **SIZE)


def test_more_samples_lower_the_error(scene):
    _, few = pathmix.render(scene, spp=4, return_error=True, **SIZE)
    _, many = pathmix.render(scene, spp=64, return_error=True, **SIZE)
    assert many.mean() < 0.5 * few.mean()


def test_a_bad_scene_raises_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(CORNELL.read_text().replace("vfov = 40", "vfov = -40"))
    with pytest.raises(pathmix.SceneError) as raised:
        pathmix.load(bad)
    assert isinstance(raised.value, ValueError)
    message = str(raised.value)
    assert "bad.toml" in message and "vfov" in message
    cli_run = subprocess.run([str(cli()), "render", str(bad), "-q"], capture_output=True,
                             text=True)
    assert cli_run.returncode == 2
    assert f"pathmix: error: {message}" in cli_run.stderr


def test_a_missing_file_raises_scene_error(tmp_path):
    with pytest.raises(pathmix.SceneError, match="missing.toml"):
        pathmix.load(tmp_path / "missing.toml")


def test_bad_arguments_raise_value_error(scene):
    with pytest.raises(ValueError, match="strategy"):
        pathmix.render(scene, spp=1, strategy="sideways", **SIZE)
    with pytest.raises(ValueError, match="width"):
        pathmix.render(scene, spp=1, width=0, height=4)
    for setting in ["sampler", "light_selection", "reconstruction", "adaptive_metric"]:
        with pytest.raises(ValueError, match=f"{setting}: `sideways` is not one of"):
            pathmix.render(scene, spp=1, **{setting: "sideways"}, **SIZE)
    with pytest.raises(ValueError, match="rr_depth: a number of bounces"):
        pathmix.render(scene, spp=1, rr_depth="never", **SIZE)


def test_info_describes_the_scene(scene):
    info = scene.info()
    assert (info["width"], info["height"], info["spp"]) == (600, 600, 1000)
    assert info["strategy"] == "mixture"
    assert (info["light_selection"], info["reconstruction"]) == ("spatial", "importance")
    assert info["adaptive_metric"] is None  # the run's default
    assert info["source"].endswith("cornell.toml")
    assert info["materials"] > 0 and info["shapes"] > 0


def test_a_progressive_run_stops_when_asked(scene):
    with pathmix.Session(scene, spp=64, seed=7, **SIZE) as session:
        steps = []
        for step in session.run(every=4):
            steps.append(step)
            if step.samples >= 8:
                break
    assert [s.samples for s in steps] == [4, 8]
    assert steps[-1].image.shape == (24, 32, 3)
    assert steps[-1].error is not None and steps[-1].elapsed > 0.0


def test_a_progressive_run_ends_at_its_samples(scene):
    with pathmix.Session(scene, spp=12, seed=7, **SIZE) as session:
        steps = list(session.run(every=8))
    assert [s.samples for s in steps] == [8, 12]
    # Its steps add up to the one render of as many samples.
    image = pathmix.render(scene, spp=12, seed=7, return_error=True, **SIZE)[0]
    assert np.array_equal(steps[-1].image, image)


def test_a_closed_session_refuses_steps(scene):
    session = pathmix.Session(scene, spp=4, **SIZE)
    session.close()
    with pytest.raises(ValueError, match="closed"):
        next(session.run(every=4))


def test_renders_from_several_threads_at_once(scene):
    seeds = [1, 2, 3]
    alone = {seed: pathmix.render(scene, spp=8, seed=seed, **SIZE) for seed in seeds}
    together = {}

    def render(seed):
        together[seed] = pathmix.render(scene, spp=8, seed=seed, **SIZE)

    threads = [threading.Thread(target=render, args=(seed,)) for seed in seeds]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for seed in seeds:
        assert np.array_equal(together[seed], alone[seed])


def test_ctrl_c_stops_a_render_with_keyboard_interrupt():
    script = (
        "import sys, pathmix\n"
        "scene = pathmix.load(sys.argv[1])\n"
        "print('rendering', flush=True)\n"
        "pathmix.render(scene, spp=1_000_000, width=32, height=24)\n"
    )
    child = subprocess.Popen([sys.executable, "-c", script, str(CORNELL)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline() == "rendering\n"
    time.sleep(0.5)
    started = time.monotonic()
    child.send_signal(signal.SIGINT)
    # Far more samples than render in this time: the render stopped early.
    _, stderr = child.communicate(timeout=60)
    assert time.monotonic() - started < 30.0
    assert child.returncode != 0
    assert stderr.rstrip().endswith("KeyboardInterrupt")


def test_a_session_resumes_from_its_checkpoint(scene, tmp_path):
    checkpoint = tmp_path / "run.ckpt"
    with pathmix.Session(scene, spp=12, seed=7, checkpoint=checkpoint, **SIZE) as first:
        for step in first.run(every=4):
            if step.samples >= 8:
                break
    with pathmix.Session(scene, spp=12, resume=checkpoint) as resumed:
        steps = list(resumed.run(every=4))
    assert [s.samples for s in steps] == [12]
    for recorded in [{"seed": 8}, {"light_selection": "uniform"}]:
        with pytest.raises(ValueError, match="resume"):
            pathmix.Session(scene, resume=checkpoint, **recorded)
    whole = pathmix.render(scene, spp=12, seed=7, return_error=True, **SIZE)[0]
    assert np.array_equal(steps[-1].image, whole)


def test_progress_reports_each_submission(scene):
    reports = []
    pathmix.render(scene, spp=4, progress=reports.append, **SIZE)
    assert reports and reports[-1]["samples"] == 4
    assert reports[-1]["max_samples"] == 4


def test_exr_and_png_round_trip(tmp_path):
    image = np.random.default_rng(0).random((5, 7, 3), dtype=np.float32)
    pathmix.write_exr(tmp_path / "a.exr", image)
    assert np.array_equal(pathmix.read_exr(tmp_path / "a.exr"), image)
    pathmix.write_png(tmp_path / "a.png", image)
    assert (tmp_path / "a.png").read_bytes().startswith(b"\x89PNG")


def test_converge_returns_the_table(scene, tmp_path):
    rows = pathmix.converge(scene, variants=["cosine", "mixture"], max_spp=16, width=16,
                            height=12, reference_spp=256, out=tmp_path)
    assert [(r["variant"], r["spp"]) for r in rows] == [
        (variant, spp) for variant in ["bsdf", "mixture:0.5"] for spp in [1, 4, 16]
    ]
    cosine = [r for r in rows if r["variant"] == "bsdf"]
    assert cosine[-1]["rmse"] < cosine[0]["rmse"]
    # Not monotone at a few samples: one bright sample in a dark pixel decides it.
    assert all(np.isfinite(r["relative_mse"]) and r["relative_mse"] > 0 for r in rows)
    assert list(tmp_path.glob("reference-*.exr")), "the reference is cached in `out`"
    with pytest.raises(ValueError, match="variants"):
        pathmix.converge(scene, variants=["sideways"])


@pytest.mark.filterwarnings("ignore:.*approximated")
def test_parameters_set_a_mitsuba_scenes_defaults(tmp_path):
    xml = tmp_path / "scene.xml"
    xml.write_text(
        '<scene version="3.0.0"><default name="res" value="8"/>'
        '<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm">'
        '<integer name="width" value="$res"/><integer name="height" value="$res"/></film>'
        '</sensor><shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/>'
        "</emitter></shape></scene>"
    )
    # What a Mitsuba file's reading approximates is a warning, not output.
    with pytest.warns(UserWarning, match="approximated: max_depth"):
        assert pathmix.load(xml).info()["width"] == 8
    assert pathmix.load(xml, res=12).info()["width"] == 12
    with pytest.raises(pathmix.SceneError, match="parameter"):
        pathmix.load(CORNELL, res=12)
