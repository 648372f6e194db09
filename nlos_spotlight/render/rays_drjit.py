"""Occlusion rays through Mitsuba 3 / Dr.Jit: the same answers as ``rays.RayEngine``, faster, and on a GPU.

``RayEngine`` (embreex) casts one ray at a time from a Cython loop; Mitsuba's ``Scene.ray_test``
casts a whole array at once, in SIMD packets on the CPU (LLVM backend, Embree inside) and through
OptiX on an NVIDIA GPU (CUDA backend). ``benchmarks/render_throughput.py`` measures the renderer's
people per second either way (``rays.RAY_BACKENDS``).

A person's rays must see the room and the body together. Instead of a new BVH over both for
every person, the room is a Mitsuba *shapegroup* built once and instanced beside each body:
:meth:`DrJitRays.with_body`.

Rays are float32 in both engines (Embree's own precision); the tests hold the two engines'
answers equal on the renderer's pair rays (``tests/render/test_rays_drjit.py``).
"""

from __future__ import annotations

import functools

import numpy as np

CHUNK = 1 << 23
"""Rays per Dr.Jit call; bounds the temporary arrays (about 40 bytes a ray)."""
VARIANTS = {"cpu": "llvm_ad_rgb", "cuda": "cuda_ad_rgb"}
"""Mitsuba variant per device type (rays only: no spectral or differentiable work is done here)."""


@functools.lru_cache(maxsize=None)
def available(device: str = "cpu") -> bool:
    """Whether Mitsuba 3 imports and casts a ray on ``device`` ('cpu' or 'cuda') here (a CUDA build
    without the driver's OptiX fails only when it traces, so one ray is traced)."""
    try:
        engine = DrJitRays(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]), device)
        hit = engine.occluded_rays(np.array([[0.2, 0.2, -1.0]]), np.array([[0.0, 0.0, 1.0]]), np.array([2.0]))
        return bool(hit[0])
    except Exception:  # not installed, or the backend (LLVM, CUDA driver, OptiX) missing
        return False


@functools.lru_cache(maxsize=None)
def _quiet() -> None:
    """Dr.Jit's log at errors only: not the kernel cache's races between the fit's processes."""
    import drjit as dr

    dr.set_log_level(dr.LogLevel.Error)


def _mitsuba(device: str, threads: int | None = None):
    """The mitsuba module with ``device``'s variant set (objects made under another variant keep
    working, so the reference renderer's and these can alternate in one process). ``threads``:
    Dr.Jit's CPU pool size, set before the variant is."""
    import drjit as dr
    import mitsuba as mi

    _quiet()
    if threads is not None and dr.thread_count() != threads:
        dr.set_thread_count(threads)
    want = VARIANTS[device]
    if mi.variant() != want:
        mi.set_variant(want)
    return mi


def _mesh(mi, vertices: np.ndarray, faces: np.ndarray, name: str):
    import drjit as dr

    m = mi.Mesh(name, len(vertices), len(faces), has_vertex_normals=False, has_vertex_texcoords=False)
    p = mi.traverse(m)
    p["vertex_positions"] = dr.ravel(mi.Point3f(np.ascontiguousarray(vertices, np.float32).T))
    p["faces"] = dr.ravel(mi.Vector3u(np.ascontiguousarray(faces, np.uint32).T))
    p.update()
    return m


class DrJitRays:
    """Occlusion queries against a triangle mesh (and, through :meth:`with_body`, a body beside it).

    Args:
        vertices: (V, 3) positions, m.
        faces: (F, 3) vertex indices.
        device: 'cpu' (LLVM backend) or 'cuda' (OptiX).
        threads: CPU threads Dr.Jit may use (None: as many as torch uses when a query runs).
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, device: str = "cpu", threads: int | None = None):
        if device not in VARIANTS:
            raise ValueError(f"ray device: expected one of {', '.join(VARIANTS)}, got {device!r}")
        self.device = device
        self.threads = threads
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        mi = self._mi()
        self._group = mi.load_dict({"type": "shapegroup", "mesh": _mesh(mi, self.vertices, self.faces, "static")})
        self._scene = mi.load_dict({"type": "scene", "static": {"type": "instance", "shapegroup": self._group}})

    def _mi(self):
        if self.device != "cpu":
            return _mitsuba(self.device)
        n = self.threads
        if n is None:  # the renderer's thread budget (the fit's workers split the cores)
            import torch

            n = torch.get_num_threads()
        # 0: the calling thread alone; a pool's idle workers spin, taking the core from the pair loops
        return _mitsuba(self.device, 0 if n <= 1 else int(n))

    def with_body(self, body) -> "DrJitRays":
        """An engine over this mesh and ``body`` (``vertices``, ``faces``) together; the mesh's BVH is
        shared, not rebuilt."""
        mi = self._mi()
        other = object.__new__(DrJitRays)
        other.device, other.threads, other._group = self.device, self.threads, self._group
        other.vertices = np.concatenate([self.vertices, np.asarray(body.vertices, np.float64)])
        other.faces = np.concatenate([self.faces, np.asarray(body.faces, np.int64) + len(self.vertices)])
        other._scene = mi.load_dict({"type": "scene", "static": {"type": "instance", "shapegroup": self._group},
                                     "body": _mesh(mi, body.vertices, body.faces, "body")})
        return other

    def occluded_rays(self, origins: np.ndarray, dirs: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """(N,) bool: a triangle lies within ``lengths`` along each unit direction (as ``RayEngine``)."""
        mi = self._mi()
        n = len(origins)
        out = np.zeros(n, dtype=bool)
        for s in range(0, n, CHUNK):
            sl = slice(s, s + CHUNK)
            ray = mi.Ray3f(mi.Point3f(np.ascontiguousarray(origins[sl], np.float32).T),
                           mi.Vector3f(np.ascontiguousarray(dirs[sl], np.float32).T))
            ray.maxt = mi.Float(np.ascontiguousarray(lengths[sl], np.float32))
            out[sl] = self._scene.ray_test(ray).numpy()
        return out

    def occluded(self, a: np.ndarray, b: np.ndarray, normal_a=None, normal_b=None) -> np.ndarray:
        """(N,) bool: something blocks the open segment a -> b (ends pushed off as ``RayEngine.occluded``)."""
        from .rays import segment_rays

        return self.occluded_rays(*segment_rays(a, b, normal_a, normal_b))


__all__ = ["CHUNK", "DrJitRays", "VARIANTS", "available"]
