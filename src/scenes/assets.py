"""Files a scene refers to: photographs (textures) and triangle meshes, loaded once per process.

A photograph is named by ``"skimage:<name>"`` (one of :data:`scenes.spec.SKIMAGE_PHOTOS`, shipped
with scikit-image: no download), an image file (anything Pillow reads) or a folder of image files
(sorted by name; the texture's seed chooses one). A mesh is a file trimesh loads (OBJ, PLY, STL,
GLB/glTF, OFF, ...); a file holding a scene of several meshes is concatenated with their
transforms applied. Paths are used as written (relative ones from the working directory).

Whatever cannot be loaded raises :class:`AssetError` (a :class:`~stereoforge.errors.SceneError`,
so the command line reports it as one ``Error:`` line naming the file and the fix). Loaded arrays
are cached per process, keyed by the path and the file's size and modification time, and are
read-only.
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from stereoforge.errors import SceneError

__all__ = ["AssetError", "IMAGE_SUFFIXES", "MESH_SUFFIXES", "MeshData", "check_photo_source",
           "list_mesh_folder", "load_photo", "load_mesh_file", "list_folder"]

#: File suffixes a photograph folder is searched for (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".ppm", ".pgm")
_SKIMAGE = "skimage:"


class AssetError(SceneError):
    """A photograph or mesh file a scene refers to is missing or cannot be read."""


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _as_rgb(arr: np.ndarray, where: str) -> np.ndarray:
    """An image array as (H, W, 3) uint8 (grey repeated; alpha dropped)."""
    arr = np.asarray(arr)
    if arr.dtype == bool:
        arr = arr.astype(np.uint8) * 255
    if arr.dtype != np.uint8:
        if np.issubdtype(arr.dtype, np.floating) and arr.size and 0.0 <= arr.min() <= arr.max() <= 1.0:
            arr = np.rint(arr * 255.0).astype(np.uint8)
        else:
            raise AssetError(f"{where}: expected an 8-bit image, got dtype {arr.dtype}; "
                             "save it as 8-bit PNG or JPEG")
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or min(arr.shape[:2]) < 2:
        raise AssetError(f"{where}: expected a grey or RGB image of at least 2 x 2 pixels, got "
                         f"shape {arr.shape}")
    return np.ascontiguousarray(arr[:, :, :3])


def list_folder(folder: str) -> list[str]:
    """The image files of ``folder`` (by :data:`IMAGE_SUFFIXES`), sorted by name."""
    files = sorted(str(p) for p in Path(folder).iterdir()
                   if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise AssetError(f"photograph folder {folder!r} holds no image file "
                         f"({', '.join(IMAGE_SUFFIXES)}); add images or name a file")
    return files


#: File suffixes a mesh folder is searched for, in every subfolder (case-insensitive).
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".glb", ".gltf", ".off")


def list_mesh_folder(folder: str) -> list[str]:
    """The mesh files under ``folder`` (by :data:`MESH_SUFFIXES`, subfolders included, as
    ShapeNet's and Objaverse's trees nest them), sorted by path; listed once per process.

    Raises
    ------
    AssetError
        If ``folder`` holds no mesh file.
    """
    files = _mesh_folder(str(Path(folder)))
    if not files:
        raise AssetError(f"mesh folder {folder!r} holds no mesh file "
                         f"({', '.join(MESH_SUFFIXES)}, subfolders included); add meshes or "
                         "name a file")
    return list(files)


@functools.lru_cache(maxsize=8)
def _mesh_folder(folder: str) -> tuple[str, ...]:
    return tuple(sorted(str(p) for p in Path(folder).rglob("*")
                        if p.suffix.lower() in MESH_SUFFIXES and p.is_file()))


def check_photo_source(source: str) -> None:
    """Refuse, before any rendering, a photograph source that cannot give a texture: an unknown
    ``skimage:`` name, a missing path, a folder without images, a file (or a folder's file) that
    is not an image, is damaged (Pillow's ``verify``) or is too large (the decompression-bomb
    limit). Reads headers and checksums, decodes no pixel.

    Raises
    ------
    AssetError
        One line naming the file and the fix.
    """
    if source.startswith(_SKIMAGE):
        from scenes.spec import SKIMAGE_PHOTOS

        if source[len(_SKIMAGE):] not in SKIMAGE_PHOTOS:
            raise AssetError(f"unknown scikit-image photograph {source!r}; valid names: "
                             f"{', '.join(SKIMAGE_PHOTOS)}")
        return
    fix = "check the path (relative paths start from the working directory)"
    if not os.path.exists(source):
        raise AssetError(f"photograph {source!r} does not exist; {fix}")
    for path in (list_folder(source) if os.path.isdir(source) else [source]):
        _check_photo_file(path)


@contextlib.contextmanager
def _pillow(path: str, damaged: str) -> Iterator[None]:
    """Pillow's failures on the photograph ``path`` as one :class:`AssetError` each (its
    warning of a huge image too: refused, one line)."""
    import warnings

    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            yield
    except (Image.DecompressionBombWarning, Image.DecompressionBombError) as exc:
        raise AssetError(f"photograph {path!r} is too large to be a texture ({exc}); give an "
                         f"image of at most {Image.MAX_IMAGE_PIXELS} pixels") from None
    except UnidentifiedImageError:
        raise AssetError(f"photograph {path!r} is not an image Pillow can read; give a PNG, "
                         "JPEG, TIFF, BMP or WebP file") from None
    except (OSError, ValueError, SyntaxError) as exc:  # truncated or corrupt image data
        raise AssetError(f"photograph {path!r} {damaged} ({exc}); re-save the image") from None


def _check_photo_file(path: str) -> None:

    from PIL import Image

    if not os.path.isfile(path):
        raise AssetError(f"photograph {path!r} is not a regular file (a named pipe, a device?); "
                         "give an image file")
    with _pillow(path, "is damaged"):
        with Image.open(path) as img:  # open applies the limit load_photo applies
            width, height = img.size
            img.verify()
    if min(width, height) < 2:
        raise AssetError(f"photograph {path!r} is {width}x{height}; a texture needs at least "
                         "2 x 2 pixels")


def _stamp(path: str, what: str, fix: str) -> tuple[int, int]:
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise AssetError(f"{what} {path!r} does not exist; {fix}") from None
    except OSError as exc:
        raise AssetError(f"{what} {path!r} cannot be read: {exc.strerror}; {fix}") from None
    return st.st_size, st.st_mtime_ns


def load_photo(source: str) -> np.ndarray:
    """The photograph ``source`` names (``skimage:<name>`` or an image file) as (H, W, 3) uint8.

    Raises
    ------
    AssetError
        If the file does not exist, is not an image Pillow reads, or the skimage name is unknown.

    Examples
    --------
    >>> load_photo("skimage:brick").shape
    (512, 512, 3)
    """
    if source.startswith(_SKIMAGE):
        return _skimage_photo(source[len(_SKIMAGE):])
    fix = "check the path (relative paths start from the working directory)"
    if os.path.isdir(source):
        raise AssetError(f"photograph {source!r} is a folder; load_photo needs a file "
                         "(a TextureSpec's image may name a folder)")
    return _file_photo(source, *_stamp(source, "photograph", fix))


@functools.lru_cache(maxsize=32)
def _skimage_photo(name: str) -> np.ndarray:
    from scenes.spec import SKIMAGE_PHOTOS

    if name not in SKIMAGE_PHOTOS:
        raise AssetError(f"unknown scikit-image photograph {name!r}; valid names: "
                         f"{', '.join(SKIMAGE_PHOTOS)}")
    import skimage.data  # lazily: only scenes with photographs need scikit-image

    return _readonly(_as_rgb(getattr(skimage.data, name)(), f"skimage:{name}"))


@functools.lru_cache(maxsize=32)
def _file_photo(path: str, size: int, mtime_ns: int) -> np.ndarray:

    from PIL import Image

    with _pillow(path, "cannot be decoded"):
        with Image.open(path) as img:
            img.load()
            if img.mode not in ("L", "RGB", "RGBA"):
                img = img.convert("RGB")
            arr = np.asarray(img)
    return _readonly(_as_rgb(arr, f"photograph {path!r}"))


class MeshData(NamedTuple):
    """A mesh file's geometry: shared vertices, faces and, if it has one, its own texture."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    uv: np.ndarray | None  # (N, 2) float64, OpenGL convention (v = 1 is image row 0)
    image: np.ndarray | None  # (h, w, 3) uint8
    closed: bool  # watertight, consistently wound, positive volume (outward normals)


def load_mesh_file(path: str) -> MeshData:
    """The triangle mesh of a file, through trimesh (a scene of several is concatenated).

    Raises
    ------
    AssetError
        If the file does not exist, trimesh cannot load it, or it holds no triangle.
    """
    return _mesh_file(path, *_stamp(path, "mesh file", "check the path (relative paths start "
                                                      "from the working directory)"))


@functools.lru_cache(maxsize=16)
def _mesh_file(path: str, size: int, mtime_ns: int) -> MeshData:
    import trimesh

    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many kinds on a bad file; one message for all
        raise AssetError(f"mesh file {path!r} cannot be loaded by trimesh "
                         f"({type(exc).__name__}: {exc}); give an OBJ, PLY, STL or GLB "
                         "file") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise AssetError(f"mesh file {path!r} holds no triangles; give a file with a "
                         "triangle mesh (OBJ, PLY, STL or GLB)")
    vertices = np.array(mesh.vertices, dtype=np.float64)
    faces = np.array(mesh.faces, dtype=np.int64)
    if not np.isfinite(vertices).all():
        raise AssetError(f"mesh file {path!r} has non-finite vertex coordinates")
    uv = image = None
    visual = mesh.visual
    if getattr(visual, "kind", None) == "texture" and visual.uv is not None:
        material = visual.material
        img = getattr(material, "image", None) or getattr(material, "baseColorTexture", None)
        if img is not None and len(visual.uv) == len(vertices):
            uv = _readonly(np.array(visual.uv, dtype=np.float64))
            image = _readonly(_as_rgb(np.asarray(img.convert("RGB")), f"texture of {path!r}"))
    try:
        closed = bool(mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0)
    except Exception:  # noqa: BLE001 - trimesh's checks may fail on odd meshes: treat as open
        closed = False
    return MeshData(_readonly(vertices), _readonly(faces), uv, image, closed)
