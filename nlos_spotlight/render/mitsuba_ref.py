"""Mitsuba 3 as the independent reference renderer.

Exports an ``nlos-scene/1`` scene to Mitsuba with the same conventions
(DESIGN section 4): ``perspective`` camera with a horizontal fov and a box
pixel filter (pixel = mean over its footprint), ``spot`` emitter, materials
``twosided(blendbsdf(0.5, diffuse(2 kd), roughconductor(none, ggx, 2 ks)))``
(the 0.5 blend of doubled lobes is the sum of the two lobes), the person as
``twosided(diffuse)``. The ``nlos`` reference is the ``path`` integrator at
``max_depth=4`` with the person minus without it, at the same seeds (paths
that never meet the person cancel exactly).
"""

from __future__ import annotations

import functools

import numpy as np

from ..scene.format import Scene, TriMesh

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
"""CPU variants, tried in order after the GPU's (``cuda_ad_rgb``, where Dr.Jit traces on CUDA here)."""

GPU_CHUNK_SPP = 1 << 16
"""Samples a pixel per ``mi.render`` call on the GPU (4,096 on the CPU): a 32 x 32 film's 67M paths
a launch keep the GPU busy; the chunking sets the seeds, so the same settings give the same image."""


@functools.lru_cache(maxsize=None)
def _cuda_traces() -> bool:
    """Whether Mitsuba's CUDA variant traces a ray here (a build without the driver's OptiX fails
    only when it traces)."""
    import mitsuba as mi

    try:
        mi.set_variant("cuda_ad_rgb")
        hit = mi.load_dict({"type": "scene", "r": {"type": "rectangle"}}).ray_test(mi.Ray3f([0, 0, -1], [0, 0, 1]))
        return bool(hit[0])
    except Exception:  # no CUDA driver, no OptiX
        return False


def use_mitsuba(device: str = "auto"):
    """Import mitsuba with the first variant that works here: the GPU's where ``device`` is 'auto' or
    'cuda' and one is present, else a CPU one (the reference is the same physics on either)."""
    import mitsuba as mi

    gpu = ("cuda_ad_rgb",) if device != "cpu" and _cuda_traces() else ()
    if device == "cuda" and not gpu:
        raise RuntimeError("Mitsuba cannot trace on a CUDA GPU here")
    for v in gpu + VARIANTS:
        try:
            if mi.variant() != v:
                mi.set_variant(v)
            return mi
        except Exception:  # a variant can be missing from the build or fail to JIT on old LLVM
            continue
    raise RuntimeError("no usable Mitsuba variant")


def _mesh(mi, name: str, m: TriMesh, bsdf: dict, attrs: dict[str, np.ndarray]):
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh(name, len(m.vertices), len(m.faces), props=props,
                   has_vertex_normals=False, has_vertex_texcoords=False)
    p = mi.traverse(mesh)
    p["vertex_positions"] = mi.Float(np.asarray(m.vertices, np.float32).ravel())
    p["faces"] = mi.UInt32(np.asarray(m.faces, np.uint32).ravel())
    p.update()
    for key, val in attrs.items():
        mesh.add_attribute(key, 3, mi.Float(np.asarray(val, np.float32).ravel()))
    return mesh


def _static_bsdf(kd_attr: str, ks: np.ndarray, alpha: float) -> dict:
    tex = {"type": "mesh_attribute", "name": kd_attr}
    if not np.any(ks > 0):
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": tex}}
    glossy = {"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": float(alpha),
              "specular_reflectance": {"type": "mesh_attribute", "name": kd_attr.replace("kd", "ks")}}
    return {"type": "twosided", "bsdf": {"type": "blendbsdf", "weight": 0.5,
                                          "bsdf_0": {"type": "diffuse", "reflectance": tex}, "bsdf_1": glossy}}


def to_mitsuba(scene: Scene, aim_point: np.ndarray, with_person: bool, max_depth: int = 4,
               emission: bool = False, person_albedo: np.ndarray | None = None, integrator: str = "path"):
    """Build the Mitsuba scene for one spot aimed at ``aim_point`` (``person_albedo`` overrides the
    body's; ``integrator``: Mitsuba's 'path' tracer or 'ptracer', its particle tracer)."""
    mi = use_mitsuba()
    T = mi.ScalarTransform4f
    cam, pr = scene.camera, scene.projector
    d = {"type": "scene", "integrator": {"type": integrator, "max_depth": max_depth},
         "sensor": {"type": "perspective", "fov": cam.fov_deg, "fov_axis": "x",
                    "to_world": T().look_at(origin=cam.position.tolist(), target=cam.look_at.tolist(),
                                            up=cam.up.tolist()),
                    "film": {"type": "hdrfilm", "width": cam.width, "height": cam.height,
                             "rfilter": {"type": "box"}, "pixel_format": "rgb"}}}
    axis = aim_point - pr.position
    up = [0.0, 0.0, 1.0] if np.linalg.norm(np.cross(axis, [0, 0, 1])) > 1e-6 * np.linalg.norm(axis) else [0, 1, 0]
    d["spot"] = {"type": "spot", "to_world": T().look_at(origin=pr.position.tolist(), target=aim_point.tolist(),
                                                         up=up),
                 "intensity": {"type": "rgb", "value": pr.intensity.tolist()},
                 "cutoff_angle": pr.cutoff_deg, "beam_width": pr.beam_width_deg}
    for i, s in enumerate(scene.shapes):
        mat, m = scene.materials[s.material], s.mesh
        scale = 2.0 if np.any(mat.specular > 0) else 1.0  # blend weight 0.5 halves each lobe
        if m.vertex_colors is not None:
            attrs = {"vertex_kd": scale * mat.diffuse * m.vertex_colors,
                     "vertex_ks": scale * np.broadcast_to(mat.specular, m.vertices.shape)}
            name = "vertex_kd"
        else:
            fc = m.face_colors if m.face_colors is not None else np.ones((len(m.faces), 3))
            attrs = {"face_kd": scale * mat.diffuse * fc, "face_ks": scale * np.broadcast_to(mat.specular, fc.shape)}
            name = "face_kd"
        shape = _mesh(mi, f"shape{i}", m, _static_bsdf(name, mat.specular, mat.roughness), attrs)
        if emission and np.any(mat.emission > 0):
            raise NotImplementedError("emission export is not needed for the nlos reference")
        d[f"shape{i}"] = shape
    if with_person and scene.human is not None:
        albedo = scene.human.albedo if person_albedo is None else np.asarray(person_albedo, dtype=np.float64)
        bsdf = {"type": "twosided", "bsdf": {"type": "diffuse",
                                              "reflectance": {"type": "rgb", "value": albedo.tolist()}}}
        d["person"] = _mesh(mi, "person", scene.human.mesh, bsdf, {})
    return mi.load_dict(d)


def render_mitsuba(mscene, spp: int, seed: int = 0, chunk_spp: int | None = None) -> np.ndarray:
    """(H, W, 3) float64 mean over ``spp`` samples, rendered in chunks with seeds seed, seed+1, ...
    (``chunk_spp``: 4,096 on the CPU, :data:`GPU_CHUNK_SPP` on the GPU)."""
    import mitsuba as mi

    if chunk_spp is None:
        chunk_spp = GPU_CHUNK_SPP if mi.variant().startswith("cuda") else 4096

    acc, done, k = 0.0, 0, 0
    while done < spp:
        n = min(chunk_spp, spp - done)
        acc = acc + n * np.array(mi.render(mscene, spp=n, seed=seed + k), dtype=np.float64)
        done += n
        k += 1
    return acc / spp


def mitsuba_nlos(scene: Scene, aim_point: np.ndarray, spp: int, seed: int = 0, max_depth: int = 4,
                 protocol: str = "presence", integrator: str = "path") -> np.ndarray:
    """Reference ``nlos`` image by path tracing at the same seeds, two protocols.

    ``presence``: the scene with the person minus the scene without (DESIGN section 5). Besides the
    light the person scatters, this includes the person's shadow on LOS-LOS-LOS paths (light relayed
    by the hidden floor or the partition's back and blocked by the body), a fourth-bounce term that
    the ``nlos`` component does not model.
    ``scatter``: the person minus a perfectly black person of the same shape: exactly the paths that
    scatter off the body, i.e. the three-bounce ``nlos`` integral when the body is hidden.
    ``blocked``: the black person minus no person: the light the body stops (``nlos_shadow``).
    presence = scatter + blocked.

    ``integrator`` 'ptracer' traces the light from the spot instead (each vertex joined to the
    camera): the spot lights a small patch and the camera sees the walls the body lights, so at
    the same cost its difference images are far less noisy than the camera-side 'path' tracer's.
    """
    black = dict(person_albedo=np.zeros(3))
    pairs = {"presence": ((True, {}), (False, {})), "scatter": ((True, {}), (True, black)),
             "blocked": ((True, black), (False, {}))}
    if protocol not in pairs:
        raise ValueError(f"unknown protocol {protocol!r}")
    (pa, ka), (pb, kb) = pairs[protocol]
    return (render_mitsuba(to_mitsuba(scene, aim_point, pa, max_depth, integrator=integrator, **ka), spp, seed)
            - render_mitsuba(to_mitsuba(scene, aim_point, pb, max_depth, integrator=integrator, **kb), spp, seed))


PHOTOGRAPH_DEPTH = 6
"""``max_depth`` of a Mitsuba photograph of a person: two bounces past ours (the spot's light reaches
the body after one bounce and the camera after one more, plus the body's shadow on one relay bounce)."""


def mitsuba_photograph(scene: Scene, aim_point: np.ndarray, spp: int, seed: int,
                       max_depth: int = PHOTOGRAPH_DEPTH, protocol: str = "presence") -> tuple[np.ndarray, float]:
    """A person as a camera records them, by the particle tracer: the room with the person minus
    without (``presence``, at the same seeds), in two halves of ``spp`` at seeds ``seed`` and ``seed +
    500``. Returns (H, W, 3) their mean and its Monte Carlo noise, the relative L2 standard error
    that the halves' difference gives. ``protocol``: one part of it instead (:func:`mitsuba_nlos`:
    ``scatter``, the light off the body, or ``blocked``, the light the body stops)."""
    half = [mitsuba_nlos(scene, aim_point, spp // 2, seed=seed + 500 * h, max_depth=max_depth, protocol=protocol,
                         integrator="ptracer") for h in (0, 1)]
    img = (half[0] + half[1]) / 2
    return img, float(np.linalg.norm(half[0] - half[1]) / 2 / np.linalg.norm(img))


def mitsuba_direct(scene: Scene, aim_point: np.ndarray, spp: int, seed: int = 0) -> np.ndarray:
    """Reference ``direct`` image (``max_depth=2``, no person)."""
    return render_mitsuba(to_mitsuba(scene, aim_point, False, max_depth=2), spp, seed)
