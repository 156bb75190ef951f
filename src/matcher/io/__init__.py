"""File formats and real-data readers: PFM, PNG images and disparities, calib.txt,
Middlebury 2005/2006 and 2014, KITTI 2015. See ``docs/formats.md``."""

from matcher.io.calib import CALIB_KEYS, format_calib, parse_calib, read_calib
from matcher.io.datasets import (
    StereoSample,
    infer_middlebury_2005_divisor,
    load_kitti_2015,
    load_middlebury_2005,
    load_middlebury_2014,
)
from matcher.io.images import (
    KITTI_DIVISOR,
    PNG_COMPRESSION,
    decode_disparity_png,
    encode_png,
    read_disparity,
    read_image,
)
from matcher.io.pfm import PFMError, PFMHeader, encode_pfm, read_pfm, read_pfm_header, write_pfm

__all__ = [
    "CALIB_KEYS",
    "KITTI_DIVISOR",
    "PNG_COMPRESSION",
    "PFMError",
    "PFMHeader",
    "StereoSample",
    "decode_disparity_png",
    "encode_pfm",
    "encode_png",
    "format_calib",
    "infer_middlebury_2005_divisor",
    "load_kitti_2015",
    "load_middlebury_2005",
    "load_middlebury_2014",
    "parse_calib",
    "read_calib",
    "read_disparity",
    "read_image",
    "read_pfm",
    "read_pfm_header",
    "write_pfm",
]
