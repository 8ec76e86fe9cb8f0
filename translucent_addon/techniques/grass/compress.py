"""BTF compression (Shah 4.3.2): YCbCr, mean-adjusted SVD, truncated eigen-textures.

Per channel c of Y, Cb, Cr the BTF matrix F has a row per pixel and a column per (view, light)
image. Its mean image mu is removed, F - mu 1^T = U S V^T (Shah Eq. 4.1), the first n columns of U
are kept and the images become coefficients F' = U^T (F - mu 1^T) (Eq. 4.2), so that
F = mu 1^T + U F' (Eq. 4.3). We fold the mean in as basis vector 0 with coefficient 1, which makes
every reconstruction one sum (Eq. 4.4) and lets integrals over lights (the uniform sky) carry
their own weight for it. Chroma is far more coherent than luminance (Shah kept 140 Y and 5-6
chroma eigen-textures); ``choose_counts`` picks the counts for a target reconstruction error.

Sentinel pixels (no blade, depth -1) are discarded at run time; in F they hold the mean of their
image's blade pixels so that they cost no eigen-textures.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ...core.geometry import hemisphere
from .acquire import SENTINEL, BTFImages

# Linear-light BT.601 (full range): a decorrelated luminance / chroma basis (Shah 4.3.2).
RGB_TO_YCBCR = np.array([[0.299, 0.587, 0.114],
                         [-0.168736, -0.331264, 0.5],
                         [0.5, -0.418688, -0.081312]])
YCBCR_TO_RGB = np.linalg.inv(RGB_TO_YCBCR)


@dataclasses.dataclass
class Spectrum:
    """The SVD of one channel, before truncation."""

    mean: np.ndarray  # (P,) mean image
    U: np.ndarray  # (P, K) eigen-textures, decreasing significance
    singular: np.ndarray  # (K,)
    coeffs: np.ndarray  # (K, I) = U^T (F - mu 1^T)
    norm: float  # Frobenius norm of F (sentinels filled), for relative errors


@dataclasses.dataclass
class CompressedBTF:
    """What the renderer needs (stored on the ground object)."""

    basis: list  # per channel (Y, Cb, Cr): (R, R, 1 + n_c) float32; basis 0 is the mean image
    coeffs: list  # per channel: (1 + n_c, n_v, n_l + 1) float32; light n_l is the uniform sky (integral)
    depth: np.ndarray  # (n_v, R, R) float32, SENTINEL where no blade
    views: np.ndarray
    lights: np.ndarray
    height: float  # top of the grass layer, tile units
    counts: tuple  # eigen-textures kept (Y, chroma)
    errors: dict  # relative reconstruction errors of the kept counts

    @property
    def resolution(self) -> int:
        return int(self.depth.shape[1])

    def storage_bytes(self, basis_bytes: int = 2, coeff_bytes: int = 4, depth_bytes: int = 4) -> dict:
        """Bytes of the compressed BTF as the bake stores it (half-float eigen-textures, float coefficients and
        depth). The GPU holds all of it as 32-bit floats, with its lookup tables: about 1.8 times this."""
        b = sum(x.size for x in self.basis) * basis_bytes
        c = sum(x.size for x in self.coeffs) * coeff_bytes
        d = self.depth.size * depth_bytes
        return {"eigen_textures": b, "coefficients": c, "depth": d, "total": b + c + d}


def to_ycbcr(rgb: np.ndarray) -> np.ndarray:
    return rgb @ RGB_TO_YCBCR.T


def to_rgb(ycbcr: np.ndarray) -> np.ndarray:
    return ycbcr @ YCBCR_TO_RGB.T


def btf_matrices(btf: BTFImages) -> np.ndarray:
    """(3, P, I) matrices in YCbCr, pixels by images (image index = view * n_l + light), sentinel
    pixels filled with their image's blade mean."""
    n_v, n_l, R = btf.images.shape[0], btf.images.shape[1], btf.images.shape[2]
    ycc = to_ycbcr(btf.images.astype(np.float64))  # (n_v, n_l, R, R, 3)
    hit = (btf.depth != SENTINEL)[:, None, :, :, None]  # (n_v, 1, R, R, 1)
    counts = np.maximum(hit.sum(axis=(2, 3)), 1)
    mean = (ycc * hit).sum(axis=(2, 3)) / counts  # (n_v, n_l, 3)
    filled = np.where(hit, ycc, mean[:, :, None, None, :])
    return filled.reshape(n_v * n_l, R * R, 3).transpose(2, 1, 0)


def spectrum(F: np.ndarray, max_rank: int = 400) -> Spectrum:
    """Mean-adjusted SVD of one channel (Shah Eq. 4.1), through the images' Gram matrix: the matrix is
    far taller (pixels) than wide (images). Eigen-textures past ``max_rank`` are not formed (their
    singular values are kept for the error curve)."""
    F = np.asarray(F, np.float64)
    mean = F.mean(axis=1)
    A = F - mean[:, None]
    G = A.T @ A
    eigval, V = np.linalg.eigh(G)
    order = np.argsort(eigval)[::-1]
    eigval, V = np.maximum(eigval[order], 0.0), V[:, order]
    singular = np.sqrt(eigval)
    keep = singular > singular[0] * 1e-7 if singular.size and singular[0] > 0 else np.zeros(0, bool)
    singular, V = singular[keep], V[:, keep]
    r = min(max_rank, len(singular))
    U = A @ V[:, :r] / singular[:r]
    coeffs = singular[:r, None] * V[:, :r].T  # U^T A (Eq. 4.2)
    return Spectrum(mean, U, singular, coeffs, float(np.linalg.norm(F)))


def error_curve(spectra: list, norm_channel: int = 0) -> np.ndarray:
    """Relative error of each channel against the count kept, (3, K + 1): || F - F_n ||_F / || F_Y ||_F.
    All channels are measured against the luminance norm, so the errors add in one unit."""
    ref = spectra[norm_channel].norm
    curves = []
    K = max(len(s.singular) for s in spectra)
    for s in spectra:
        tail = np.concatenate([np.cumsum((s.singular ** 2)[::-1])[::-1], [0.0]])
        tail = np.concatenate([tail, np.zeros(K + 1 - len(tail))])
        curves.append(np.sqrt(tail) / ref)
    return np.array(curves)


def total_error(curves: np.ndarray, n_y: int, n_c: int) -> float:
    """Relative error of the reconstruction in all three channels together (luminance norm)."""
    K = curves.shape[1] - 1
    return float(np.sqrt(curves[0][min(n_y, K)] ** 2 + curves[1][min(n_c, K)] ** 2 + curves[2][min(n_c, K)] ** 2))


MAX_TEXTURE_TEXELS = 16384  # OpenGL 4.5's least GL_MAX_TEXTURE_SIZE: the renderer's basis texture is R x groups wide


def texture_groups(n_y: int, n_c: int) -> int:
    """Groups of four eigen-textures the renderer packs side by side (``model.packed_basis``):
    each channel keeps its mean as basis 0."""
    return -(-(n_y + 1) // 4) + 2 * -(-(n_c + 1) // 4)


def choose_counts(spectra: list, target_error: float, max_groups: int | None = None) -> tuple[int, int]:
    """(n_Y, n_chroma) reaching a total relative error <= target_error at the least storage: eigen-
    textures are added greedily by error removed per texture stored (a chroma count adds one to Cb and
    one to Cr). Chroma is more coherent than luminance, so it gets far fewer (Shah: 140 and 6).
    ``max_groups``: at most that many texture groups (``texture_groups``); the target may then be missed,
    which ``total_error`` of the counts shows."""
    curves = error_curve(spectra)
    K = min(s.U.shape[1] for s in spectra)
    sq = [np.concatenate([s.singular ** 2, [0.0]]) for s in spectra]
    limit = np.inf if max_groups is None else max_groups
    n_y = n_c = 0
    while total_error(curves, n_y, n_c) > target_error:
        gain_y = sq[0][n_y] if n_y < K and texture_groups(n_y + 1, n_c) <= limit else -1.0
        gain_c = 0.5 * (sq[1][n_c] + sq[2][n_c]) if n_c < K and texture_groups(n_y, n_c + 1) <= limit else -1.0
        if gain_y < 0 and gain_c < 0:
            break
        if gain_y >= gain_c:
            n_y += 1
        else:
            n_c += 1
    return n_y, n_c


def compress(btf: BTFImages, target_error: float = 0.05, counts: tuple | None = None,
             spectra: list | None = None) -> CompressedBTF:
    """Truncate to the counts that reach ``target_error`` (or to explicit ``counts``) and add the sky."""
    F = btf_matrices(btf)
    spectra = spectra or [spectrum(F[c]) for c in range(3)]
    n_v, n_l, R = btf.images.shape[0], btf.images.shape[1], btf.images.shape[2]
    n_y, n_c = counts if counts is not None else choose_counts(spectra, target_error, MAX_TEXTURE_TEXELS // R)
    sky_weights = hemisphere.sky_weights(btf.lights)
    basis, coeffs = [], []
    curves = error_curve(spectra)
    for c, n in enumerate((n_y, n_c, n_c)):
        s = spectra[c]
        n = min(n, s.U.shape[1])
        B = np.concatenate([s.mean[:, None], s.U[:, :n]], axis=1)  # mean as basis 0
        C = np.concatenate([np.ones((1, F.shape[2])), s.coeffs[:n]], axis=0).reshape(1 + n, n_v, n_l)
        sky = np.einsum("kvl,l->kv", C, sky_weights)  # integral over lights: uniform sky of radiance 1
        basis.append(B.reshape(R, R, 1 + n).astype(np.float32))
        coeffs.append(np.concatenate([C, sky[:, :, None]], axis=2).astype(np.float32))
    errors = {"Y": float(curves[0][min(n_y, curves.shape[1] - 1)]),
              "Cb": float(curves[1][min(n_c, curves.shape[1] - 1)]),
              "Cr": float(curves[2][min(n_c, curves.shape[1] - 1)])}
    return CompressedBTF(basis, coeffs, btf.depth.astype(np.float32), btf.views, btf.lights, btf.height,
                         (n_y, n_c), errors)


def reconstruct(cb: CompressedBTF, view: int, light: int, n_y: int | None = None) -> np.ndarray:
    """Image (R, R, 3) RGB of a sampled view and light (or light = n_l: the sky), Eq. 4.3, with the
    first n_y luminance eigen-textures."""
    out = []
    for c in range(3):
        B, C = cb.basis[c], cb.coeffs[c]
        k = B.shape[2] if (c > 0 or n_y is None) else 1 + min(n_y, B.shape[2] - 1)
        out.append(B[:, :, :k] @ C[:k, view, light])
    return to_rgb(np.stack(out, axis=-1))
