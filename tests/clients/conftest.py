"""The real stereo tools of ``../shared/clients`` (MiddEval3 SDK, KITTI devkit, RAFT-Stereo's
loaders), built once per session into a temporary folder from the unmodified copies.

The folder is ``$STEREOFORGE_CLIENTS`` or ``../shared/clients`` beside the repository; where it is
absent the tests skip with that reason (CI sets ``STEREOFORGE_REQUIRE_CLIENTS=1``: then they fail).
A missing compiler or library (g++, libpng++-dev, tcsh) fails: CI installs them (`make system`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

_DEFAULT = Path(__file__).resolve().parents[2].parent / "shared" / "clients"


@pytest.fixture(scope="session")
def clients_dir(require_or_skip) -> Path:
    path = Path(os.environ.get("STEREOFORGE_CLIENTS") or _DEFAULT)
    if not (path / "middeval3_sdk").is_dir():
        require_or_skip(f"stereo clients not found at {path} (expected middeval3_sdk/, kitti_devkit/, "
                        "raft_stereo/); set STEREOFORGE_CLIENTS", env="STEREOFORGE_REQUIRE_CLIENTS")
    return path


def _run(cmd: list[str], cwd: Path) -> None:
    done = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    if done.returncode:
        pytest.fail(f"{' '.join(cmd)} failed in {cwd}:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")


@pytest.fixture(scope="session")
def middeval_sdk(clients_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A build copy of the MiddEval3 SDK 1.6 (its own Makefiles): ``runeval``, ``code/evaldisp``,
    ``code/computemask``."""
    sdk = tmp_path_factory.mktemp("sdk") / "MiddEval3"
    shutil.copytree(clients_dir / "middeval3_sdk", sdk)
    for p in [sdk, *sdk.rglob("*")]:
        p.chmod(p.stat().st_mode | 0o200)
    _run(["make", "-C", "imageLib"], sdk / "code")
    _run(["make", "evaldisp", "computemask"], sdk / "code")
    if shutil.which("tcsh") is None:
        pytest.fail("tcsh is not installed (runeval is a csh script): apt-get install tcsh")
    return sdk


@pytest.fixture(scope="session")
def kitti_devkit(clients_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Callable[[int], Path]:
    """``build(n_frames)`` -> path of the devkit's ``evaluate_scene_flow`` for ``n_frames`` frames.

    The build copy gets the three edits of kitti_devkit/SOURCES.txt: ``std::min(x, 5.0f)``,
    ``inline void setInvalid`` (no return statement: undefined behaviour), and the frame count.
    """
    built: dict[int, Path] = {}

    def build(n_frames: int) -> Path:
        if n_frames not in built:
            src = tmp_path_factory.mktemp(f"kitti{n_frames}")
            shutil.copytree(clients_dir / "kitti_devkit" / "devkit" / "cpp", src, dirs_exist_ok=True)
            for name in ("io_disp.h", "io_flow.h"):
                p = src / name
                p.chmod(0o644)
                text = p.read_text().replace(",5.0)", ",5.0f)").replace(", 5.0)", ", 5.0f)")
                p.write_text(text.replace("inline bool setInvalid", "inline void setInvalid"))
            main = src / "evaluate_scene_flow.cpp"
            main.chmod(0o644)
            text = main.read_text()
            assert "#define NUM_TEST_IMAGES 200" in text
            main.write_text(text.replace("#define NUM_TEST_IMAGES 200", f"#define NUM_TEST_IMAGES {n_frames}"))
            _run(["g++", "-O2", "-o", "evaluate_scene_flow", "evaluate_scene_flow.cpp", "-lpng"], src)
            built[n_frames] = src / "evaluate_scene_flow"
        return built[n_frames]

    return build


@pytest.fixture(scope="session")
def renderer(require_or_skip):
    """A 160 x 120 renderer; skips without GL unless CI requires it (STEREOFORGE_REQUIRE_GL)."""
    from synth.render.renderer import GLBackendError, Renderer

    try:
        r = Renderer(160, 120, backend=os.environ.get("STEREOFORGE_TEST_GL_BACKEND", "auto"))
    except GLBackendError as exc:
        require_or_skip(f"no OpenGL backend: {exc}", env="STEREOFORGE_REQUIRE_GL")
    with r:
        yield r


#: The training layouts' test datasets: FlyingThings3D's size, every photometric model (so the
#: clean and final passes differ), occluders (so there are occlusions and no-ground-truth pixels).
TRAINING_CONFIG = """\
name = "layouts"
seed = 11
count = {count}

[rig]
width = {width}
height = {height}

[scene]
base = {{choice = ["boxes", "flying", "slanted_plane"]}}
occluders = {{uniform = [1, 3]}}

[photometric]
noise_sigma = {{uniform = [1.0, 3.0]}}
gain = {{uniform = [0.9, 1.1]}}
bias = {{uniform = [-5.0, 5.0]}}
"""


@pytest.fixture(scope="session")
def training_layouts(renderer, tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Path]:
    """``make(name)`` -> a dataset folder: ``sceneflow`` (24 samples at 960x540, the size the
    codebases assume), its ``middlebury`` twin and ``middlebury-clean`` (the same config without
    the photometric models: the clean pass); ``crestereo``, ``fsd`` and their ``middlebury-small``
    twin (8 samples at 320x240). Each is rendered once per session, when first asked for."""
    from synth.dataset.config.parse import loads_config
    from synth.dataset.run import run_dataset

    made: dict[str, Path] = {}
    base = tmp_path_factory.mktemp("layouts")

    def make(name: str) -> Path:
        if name not in made:
            big = name in ("sceneflow", "middlebury", "middlebury-clean")
            text = TRAINING_CONFIG.format(count=24 if big else 8, width=960 if big else 320,
                                          height=540 if big else 240)
            if name == "middlebury-clean":
                text = text[:text.index("[photometric]")]
            fmt = name.split("-")[0]
            out = base / name
            run_dataset(loads_config(text, source=f"{name}.toml"), out=out, fmt=fmt,
                         workers=2, progress=False)
            made[name] = out
        return made[name]

    return make
