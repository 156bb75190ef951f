"""Every stereo file format, read and write, one module per format (see ``docs/formats.md``):
PFM (:mod:`~matcher.io.pfm`), PNG images and disparities (:mod:`~matcher.io.png`), ``calib.txt``
(:mod:`~matcher.io.calib`), the Middlebury 2005/2006 and 2014 layouts
(:mod:`~matcher.io.middlebury`), KITTI 2015 (:mod:`~matcher.io.kitti`), Middlebury ``.flo`` flow
(:mod:`~matcher.io.flo`), the disparity PNGs of CREStereo (:mod:`~matcher.io.crestereo`) and
FoundationStereo's FSD (:mod:`~matcher.io.fsd`), 4:4:4 JPEG images (:mod:`~matcher.io.jpeg`), and
atomic file writes (:mod:`~matcher.io.atomic`). The writers take arrays and plain values."""

from matcher.io.atomic import atomic_write_bytes, save_figure_atomic, write_all_atomic
from matcher.io.calib import CALIB_KEYS, format_calib, parse_calib, read_calib
from matcher.io.crestereo import (
    CRESTEREO_MAX,
    CRESTEREO_SCALE,
    check_crestereo_range,
    decode_crestereo_disparity,
    encode_crestereo_disparity,
    read_crestereo_disparity,
)
from matcher.io.flo import FloError, decode_flo, encode_flo, read_flo, write_flo
from matcher.io.fsd import (
    FSD_BASE,
    FSD_MAX,
    FSD_SCALE,
    check_fsd_range,
    decode_fsd_disparity,
    encode_fsd_disparity,
    read_fsd_disparity,
)
from matcher.io.jpeg import JPEG_MAX_SIDE, JPEG_MIN_QUALITY, encode_jpeg
from matcher.io.kitti import (
    KITTI_MAX_DISPARITY,
    encode_kitti_disparity,
    format_kitti_calib,
    load_kitti_2015,
    parse_kitti_calib,
    read_kitti_calib,
    write_kitti,
)
from matcher.io.middlebury import (
    GT_FILES,
    GT_NAMES,
    REQUIRED_CALIB_KEYS,
    DivisorSource,
    check_middlebury_2005_divisor,
    find_middlebury_2005_divisor,
    infer_middlebury_2005_divisor,
    load_middlebury_2005,
    load_middlebury_2014,
    write_middlebury,
)
from matcher.io.pfm import (
    PFMError,
    PFMHeader,
    decode_pfm,
    encode_pfm,
    read_pfm,
    read_pfm_header,
    write_pfm,
)
from matcher.io.png import (
    DEFLATE,
    DEFLATES,
    GREY_DEFLATE,
    KITTI_DIVISOR,
    check_deflate,
    decode_disparity_png,
    deflate_for,
    encode_png,
    read_disparity,
    read_grey_image,
    read_image,
)
from matcher.io.sample import StereoSample, check_stereo_images

__all__ = [
    "CALIB_KEYS",
    "CRESTEREO_MAX",
    "CRESTEREO_SCALE",
    "DEFLATE",
    "DEFLATES",
    "check_deflate",
    "FSD_BASE",
    "FSD_MAX",
    "FSD_SCALE",
    "FloError",
    "GREY_DEFLATE",
    "GT_FILES",
    "GT_NAMES",
    "JPEG_MAX_SIDE",
    "JPEG_MIN_QUALITY",
    "KITTI_DIVISOR",
    "KITTI_MAX_DISPARITY",
    "PFMError",
    "PFMHeader",
    "REQUIRED_CALIB_KEYS",
    "StereoSample",
    "DivisorSource",
    "atomic_write_bytes",
    "check_crestereo_range",
    "check_middlebury_2005_divisor",
    "check_fsd_range",
    "check_stereo_images",
    "decode_crestereo_disparity",
    "decode_disparity_png",
    "decode_flo",
    "decode_fsd_disparity",
    "decode_pfm",
    "deflate_for",
    "encode_crestereo_disparity",
    "encode_flo",
    "encode_fsd_disparity",
    "encode_jpeg",
    "encode_kitti_disparity",
    "encode_pfm",
    "encode_png",
    "find_middlebury_2005_divisor",
    "format_calib",
    "format_kitti_calib",
    "infer_middlebury_2005_divisor",
    "load_kitti_2015",
    "load_middlebury_2005",
    "load_middlebury_2014",
    "parse_calib",
    "parse_kitti_calib",
    "read_calib",
    "read_crestereo_disparity",
    "read_disparity",
    "read_flo",
    "read_fsd_disparity",
    "read_grey_image",
    "read_image",
    "read_kitti_calib",
    "read_pfm",
    "read_pfm_header",
    "save_figure_atomic",
    "write_all_atomic",
    "write_flo",
    "write_kitti",
    "write_middlebury",
    "write_pfm",
]
