"""Error metrics of docs/design.md ("Metrics"), image space: RMSE on linear RGB, mean CIEDE2000 after a
fixed tone map (colour-science), FLIP (flip-evaluator) -- always over a mask of the pixels that
matter (the sphere), so a background shared by both images does not dilute the figures.

The fixed tone map is the one every figure in bench/images.md uses: exposure 1, Reinhard
x / (1 + x) per channel on linear Rec.709/sRGB primaries, then CIE Lab under D65. It keeps
highlights above 1 distinguishable instead of clipping them.
"""
from __future__ import annotations

import numpy as np


def _rgb(img: np.ndarray) -> np.ndarray:
    return np.asarray(img, dtype=np.float64)[..., :3]


def rmse(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """Root mean square difference of linear RGB over the masked pixels (all channels)."""
    d = _rgb(img)[mask] - _rgb(ref)[mask]
    return float(np.sqrt(np.mean(d * d)))


def block_mean(img: np.ndarray, mask: np.ndarray, block: int):
    """Mean linear RGB over ``block``x``block`` tiles that lie entirely inside the mask:
    (tiles, 3). Comparing tiles instead of pixels divides uncorrelated per-pixel noise by
    ``block`` and keeps the errors a layer model makes (smooth over the sphere)."""
    h, w = mask.shape
    hb, wb = h // block, w // block
    rgb = _rgb(img)[: hb * block, : wb * block].reshape(hb, block, wb, block, 3)
    full = mask[: hb * block, : wb * block].reshape(hb, block, wb, block).all(axis=(1, 3))
    return rgb.mean(axis=(1, 3))[full]


def block_rmse(img: np.ndarray, ref: np.ndarray, mask: np.ndarray, block: int = 8) -> float:
    d = block_mean(img, mask, block) - block_mean(ref, mask, block)
    return float(np.sqrt(np.mean(d * d)))


def mean_bias(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    """Relative error of the mean radiance over the mask (RGB averaged): the energy a model
    gains or loses, which converges long before per-pixel noise does."""
    a, b = _rgb(img)[mask].mean(0), _rgb(ref)[mask].mean(0)
    return float(np.mean((a - b) / np.maximum(b, 1e-12)))


def tone_map_lab(img: np.ndarray) -> np.ndarray:
    """The fixed tone map: Reinhard per channel, then linear sRGB -> XYZ -> CIE Lab (D65)."""
    import colour

    rgb = np.maximum(_rgb(img), 0.0)
    tm = rgb / (1.0 + rgb)
    xyz = colour.RGB_to_XYZ(tm, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])


def display_srgb(img: np.ndarray) -> np.ndarray:
    """The fixed tone map (Reinhard per channel), sRGB-encoded in [0, 1] for PNGs and contact
    sheets: what the ΔE00 figures judge is what the pictures show."""
    import colour

    rgb = np.maximum(_rgb(img), 0.0)
    return np.clip(colour.cctf_encoding(rgb / (1.0 + rgb), function="sRGB"), 0.0, 1.0)


def delta_e00_map(img: np.ndarray, ref: np.ndarray) -> np.ndarray:
    import colour

    return colour.delta_E(tone_map_lab(img), tone_map_lab(ref), method="CIE 2000")


def mean_delta_e00(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    return float(delta_e00_map(img, ref)[mask].mean())


def flip_map(img: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """HDR-FLIP error map (flip-evaluator, default exposure range and tone mapper)."""
    import flip_evaluator

    err, _, _ = flip_evaluator.evaluate(np.ascontiguousarray(np.maximum(_rgb(ref), 0.0), dtype=np.float32),
                                        np.ascontiguousarray(np.maximum(_rgb(img), 0.0), dtype=np.float32),
                                        "HDR", applyMagma=False, computeMeanError=False)
    return np.asarray(err).reshape(np.shape(img)[:2])


def mean_flip(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    return float(flip_map(img, ref)[mask].mean())


def image_errors(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> dict:
    """All image-space figures of one render against its reference."""
    return {"rmse": rmse(img, ref, mask), "rmse_8px": block_rmse(img, ref, mask, 8),
            "mean_bias": mean_bias(img, ref, mask), "delta_e00": mean_delta_e00(img, ref, mask),
            "flip": mean_flip(img, ref, mask)}
