"""Write one rendered stereo pair to disk: dataset layout, ``scene.json`` and ``preview.png``.

This is the library function behind ``stereoforge render`` (and the demo); the CLI only parses.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from collections.abc import Mapping
from importlib import metadata
from pathlib import Path

import numpy as np

from matcher.io import atomic_write_bytes, check_deflate, encode_png
from scenes import PRESETS, SceneSpec, get_preset, load_scene, scene_to_dict
from stereoforge.errors import DatasetError
from stereoforge.validation import check_input_file
from synth._util.json_records import json_bytes
from synth.formats import DEFAULT_FORMAT, FORMATS, get_layout
from synth.formats.kitti import KITTI_ROOT, foreground_map, kitti_calib_for
from synth.formats.middlebury import calib_for
from synth.pair import StereoPair
from synth.write.preview import preview_image

__all__ = ["FORMATS", "KITTI_ROOT", "OutputDirError", "resolve_scene", "prepare_output_dir",
           "staged_output_dir", "calib_for", "kitti_calib_for", "foreground_map", "write_pair",
           "save_pair"]

class OutputDirError(DatasetError):
    """The output directory cannot be used as asked."""


def resolve_scene(scene: str, *, seed: int | None = None) -> tuple[SceneSpec, int]:
    """A preset name or a scene file (``.toml``/``.json``) to a scene and its seed.

    Parameters
    ----------
    scene : str
        Preset name (see ``stereoforge presets``) or path to a scene file.
    seed : int, optional
        Seed of a preset (default 0). A scene file carries its own seeds, so passing ``seed``
        with a file is an error.

    Returns
    -------
    (SceneSpec, int)
    """
    path = Path(scene)
    if path.suffix.lower() in (".toml", ".json") or (scene not in PRESETS and path.is_dir()):
        check_input_file(path, "scene file", suffixes=(".toml", ".json"),
                         fix="pass a .toml or .json scene file, or a preset name (stereoforge "
                             "presets)")
        if seed is not None:
            raise ValueError(
                f"--seed applies to presets only; the scene file {path} fixes its own seeds "
                "(edit its 'seed' fields instead)"
            )
        spec = load_scene(path)
        return spec, spec.seed
    seed = 0 if seed is None else int(seed)
    return get_preset(scene, seed=seed), seed


def prepare_output_dir(out: str | Path, *, overwrite: bool = False) -> Path:
    """Make ``out`` if needed; refuse a directory holding other content unless ``overwrite``.

    Examples
    --------
    >>> import tempfile
    >>> d = prepare_output_dir(Path(tempfile.mkdtemp()) / "new")
    >>> d.is_dir()
    True
    """
    out = Path(out)
    _check_output_dir(out, overwrite)
    out.mkdir(parents=True, exist_ok=True)
    return out


def _check_output_dir(out: Path, overwrite: bool) -> None:
    for parent in out.parents:  # the nearest existing ancestor must be a directory
        if parent.exists():
            if not parent.is_dir():
                raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(parent))
            break
    if out.exists() and not out.is_dir():
        raise OutputDirError(f"output path {out} exists and is not a directory; choose another --out")
    if out.is_dir() and not overwrite:
        entries = sorted(p.name for p in out.iterdir())
        if entries:
            shown = ", ".join(entries[:5]) + (", ..." if len(entries) > 5 else "")
            raise OutputDirError(
                f"output directory {out} already holds {len(entries)} entries ({shown}); "
                "choose an empty directory or pass --overwrite"
            )


_STAGE = re.compile(r"^\.(?P<name>.+)\.tmp-(?P<pid>\d+)-[^.]+$")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def _remove_stale_stages(out: Path) -> None:
    """Remove ``.<name>.tmp-<pid>-*`` folders of ``out`` left by a process that died."""
    for entry in out.parent.iterdir():
        m = _STAGE.match(entry.name)
        if m and m["name"] == out.name and entry.is_dir() and not _pid_alive(int(m["pid"])):
            shutil.rmtree(entry, ignore_errors=True)


def _default_dir_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o777 & ~umask


def _commit_stage(stage: Path, out: Path) -> None:
    """Move the staged files to ``out``: one rename when ``out`` is absent or empty, else each
    file atomically (``--overwrite`` of a folder holding other files, which stay)."""
    if not out.exists() or (out.is_dir() and not any(out.iterdir())):
        os.rename(stage, out)  # replaces an empty directory atomically (POSIX)
        return
    for src in sorted(stage.rglob("*")):
        if src.is_file():
            dest = out / src.relative_to(stage)
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(src, dest)
    shutil.rmtree(stage)


@contextlib.contextmanager
def staged_output_dir(out: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """A temporary folder beside ``out`` whose files become ``out``'s when the block succeeds.

    ``out`` is checked first (as :func:`prepare_output_dir` does). The block writes into the
    yielded folder (``.<name>.tmp-<pid>-*`` in ``out``'s parent, the same file system); on
    success it is renamed to ``out`` in one step (``out`` absent or empty) or, with
    ``overwrite`` and a non-empty ``out``, each file is renamed over its old version. On any
    exception (disk full, a failed render) the folder is removed and ``out`` is untouched, so a
    rerun into the same ``out`` works. A folder left by a killed process is removed by the next
    run into the same ``out``.

    Examples
    --------
    >>> d = Path(tempfile.mkdtemp())
    >>> with staged_output_dir(d / "pair") as stage:
    ...     _ = (stage / "a.txt").write_text("hi")
    >>> sorted(p.name for p in d.iterdir()), (d / "pair" / "a.txt").read_text()
    (['pair'], 'hi')
    """
    out = Path(out)
    _check_output_dir(out, overwrite)
    out.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale_stages(out)
    stage = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.tmp-{os.getpid()}-"))
    try:
        os.chmod(stage, _default_dir_mode())
        yield stage
        _commit_stage(stage, out)
    except BaseException as exc:
        shutil.rmtree(stage, ignore_errors=True)
        name = getattr(exc, "filename", None) if isinstance(exc, OSError) else None
        if name is not None and Path(name).is_relative_to(stage):  # name the final path
            raise OSError(exc.errno, exc.strerror, str(out / Path(name).relative_to(stage))) from exc
        raise


@functools.cache
def _version() -> str:
    try:
        return metadata.version("stereoforge")
    except metadata.PackageNotFoundError:  # running from a source tree
        return "unknown"


def _jsonable(value):
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def write_pair(
    pair: StereoPair,
    out: str | Path,
    *,
    scene: SceneSpec,
    seed: int,
    fmt: str = DEFAULT_FORMAT,
    index: int = 0,
    preview: bool = True,
    fsync: bool = True,
    clean: StereoPair | None = None,
    image_deflate: str | None = None,
) -> list[Path]:
    """Write ``pair`` in a dataset layout, plus ``scene.json`` and (optionally) ``preview.png``.

    Every file is written atomically (temporary name, then rename).

    Parameters
    ----------
    pair : StereoPair
    out : str or Path
        Existing directory (see :func:`prepare_output_dir`).
    scene : SceneSpec
        The fully resolved scene, stored in ``scene.json`` with the rig and seed.
    seed : int
    fmt : str
        One of :data:`synth.formats.FORMATS` (:mod:`synth.formats`). ``middlebury``: a
        MiddEval3 scene folder in ``out`` (with the pair's exposure and lighting variants as ``im1E.png``/``im1L.png`` and its highlight masks as ``mask0spec.png``/
        ``mask1spec.png`` when it has them); ``middlebury2014``: the same folder with the ground
        truth named as in the 2014 scene archives (``disp0.pfm``, ``disp1.pfm``); ``kitti``: frame
        ``index`` under
        ``out/training/`` (with ``obj_map/`` from :func:`foreground_map` and
        ``calib_cam_to_cam/``), ``scene.json`` and ``preview.png`` in ``out``. A pair of a rig
        with camera errors (``pair.flow_left`` set) also gets ``flow0.flo`` in a Middlebury
        folder and is refused in the KITTI layout. ``sceneflow``, ``crestereo``, ``fsd``: the
        training layouts of FlyingThings3D, CREStereo and FoundationStereo (docs/formats.md).
    index : int
        Frame index in the KITTI layout (sample index of the other layouts' file names).
    preview : bool
        Also write ``preview.png`` (left, right, disparity, mask).
    fsync : bool
        Flush every file to disk before its rename (survives power loss). Without it a file is
        still never half-written after a crash of the process, since it appears only by rename.
    clean : StereoPair, optional
        The pair before the sensor and photometric models, for layouts that keep both
        (``sceneflow``'s cleanpass); default ``pair``.
    image_deflate : {"isal", "libdeflate", "zlib", "stored"}, optional
        The deflate of the images' PNGs and of ``preview.png``
        (:func:`matcher.io.encode_png`; default its own); masks and disparities keep theirs,
        JPEG images are JPEG.

    Returns
    -------
    list of Path
        The files written.
    """
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; valid formats: {', '.join(FORMATS)}")
    if image_deflate is not None:
        check_deflate(image_deflate, "image_deflate")
    layout = get_layout(fmt)
    out = Path(out)
    if pair.flow_left is not None and not layout.capacity.flow:
        raise OutputDirError(f"a rig with camera errors writes its exact flow as flow0.flo in the "
                             f"middlebury layouts only, not {fmt!r}; use --format middlebury")
    written = layout.write_files(pair, out, scene=scene, index=index,
                                 clean=pair if clean is None else clean, fsync=fsync,
                                 image_deflate=image_deflate)
    record = {
        "stereoforge_version": _version(),
        "format": fmt,
        "seed": int(seed),
        "rig": pair.rig.to_dict(),
        "scene": scene_to_dict(scene),
        "render": _jsonable(dict(pair.meta)),
    }
    scene_json = out / "scene.json"
    atomic_write_bytes(scene_json, json_bytes(record), fsync=fsync)
    written.append(scene_json)
    if preview:
        img = preview_image(pair.left, pair.right, pair.disp_left, pair.mask_left)
        atomic_write_bytes(out / "preview.png", encode_png(img, deflate=image_deflate),
                           fsync=fsync)
        written.append(out / "preview.png")
    return written


def save_pair(pair: StereoPair, out: str | Path, *, scene: SceneSpec, seed: int,
              fmt: str = DEFAULT_FORMAT, overwrite: bool = False,
              ground_truth: Mapping[str, np.ndarray] | None = None) -> list[Path]:
    """Write ``pair`` as the whole folder ``out`` at once (what ``stereoforge render`` does).

    :func:`write_pair` into a :func:`staged_output_dir`: after a failure (disk full, ...)
    ``out`` is as before, never a part of the pair's files. ``ground_truth``: the optional
    arrays of :func:`synth.write.extra_ground_truth.render_ground_truth`, written beside the Middlebury
    files.

    Returns
    -------
    list of Path
        The files written, under ``out``.
    """
    out = Path(out)
    with staged_output_dir(out, overwrite=overwrite) as stage:
        written = write_pair(pair, stage, scene=scene, seed=seed, fmt=fmt)
        if ground_truth:
            from synth.formats.extras import write_ground_truth

            written += write_ground_truth(stage, ground_truth)
    return [out / p.relative_to(stage) for p in written]
