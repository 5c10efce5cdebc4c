"""Scene description for :mod:`subsurf.render`: objects (meshes or built-in shapes, each with a
transform and a material), materials, lights, a constant environment and a pinhole camera.

Units: mm for lengths; light power in W (any consistent unit: images are linear in it). Meshes
are loaded with ``trimesh`` (a base dependency: OBJ, PLY, STL, GLB) or given as a ``trimesh.Trimesh``; the core
validates them (finite vertices, non-zero area; ``random_walk`` also needs watertight meshes).
"""

from __future__ import annotations

import math
import os

import numpy as np

from .. import _core
from ..materials import get as _library
from ..medium import Layer, Stack
from .media import MediumGrid, Texture, invert_maps, to_object_map

#: The profile models (the core's list, ``subsurf_core::bssrdf::Model``).
MODELS = tuple(_core.BSSRDF_MODELS)
#: The Monte Carlo profile's defaults (the core's ``McSettings::default()``).
_MC = _core.BSSRDF_MC_DEFAULTS


def _err(msg):
    return _core.ParameterError(msg)


def _float(name, v):
    if isinstance(v, bool):
        raise _err(f"{name} = {v!r} is not a number")
    try:
        return float(v)
    except (TypeError, ValueError):
        raise _err(f"{name} = {v!r} is not a number") from None


def _size2(size):
    try:
        a = np.asarray(size, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.size == 1:
        a = np.repeat(a, 2)
    if a.size != 2:
        raise _err(f"size = {size!r}: expected [width, depth] (two numbers, mm) or one number for a square")
    return [float(x) for x in a]


def _vec3(name, v):
    try:
        a = np.asarray(v, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise _err(f"{name} = {v!r} is not a list of numbers") from None
    if a.size == 1:
        a = np.repeat(a, 3)
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise _err(f"{name} = {v!r}: expected 3 finite numbers (or one for all channels)")
    return [float(x) for x in a]


class Translucent:
    """A homogeneous scattering medium inside a smooth dielectric boundary (index ``eta``).

    Parameters: ``sigma_a``, ``sigma_s`` per RGB channel (mm⁻¹), HG ``g``, ``eta`` (n_medium / 1),
    ``model`` the BSSRDF profile used by the ``hierarchical`` and ``probe`` methods (one of
    :data:`MODELS`; ``random_walk`` ignores it). ``stacks`` (three :class:`subsurf.Stack`) gives a
    layered material to the profile models (``multipole``, ``monte_carlo``); ``mc_photons`` and
    ``mc_seed`` set the Monte Carlo profile's run; ``reflectance`` (set by :meth:`from_reflectance`)
    is the reflectance per unit incident power the material was made from, which
    ``normalized_diffusion`` takes (÷ (1 − R_sp)) as its surface albedo. ``grid`` (a
    :class:`MediumGrid`) makes the medium heterogeneous for ``random_walk`` and
    :func:`simulate_walk`: σa, σs per voxel inside its box, the values above outside it. Construct from the library
    with :meth:`library`, from layers with :meth:`from_stacks`, or from a reflectance and a mean
    free path with :meth:`from_reflectance`.
    """

    def __init__(
        self,
        sigma_a,
        sigma_s,
        g=0.0,
        eta=1.3,
        model="dipole",
        name=None,
        stacks=None,
        mc_photons=_MC["photons"],
        mc_seed=_MC["seed"],
        single_scattering=None,
        reflectance=None,
        grid=None,
    ):
        self.sigma_a = _vec3("sigma_a", sigma_a)
        self.sigma_s = _vec3("sigma_s", sigma_s)
        self.g, self.eta = float(g), float(eta)
        if model not in MODELS:
            raise _err(f"model = {model!r} is unknown: must be one of {list(MODELS)}")
        self.model, self.name = model, name
        self.stacks = list(stacks) if stacks is not None else None
        if self.stacks is not None and (len(self.stacks) != 3 or not all(isinstance(s, Stack) for s in self.stacks)):
            raise _err("stacks: give three subsurf.Stack objects, one per RGB channel")
        self.mc_photons, self.mc_seed, self.single_scattering = mc_photons, mc_seed, single_scattering  # core checks
        self.reflectance = None if reflectance is None else _vec3("reflectance", reflectance)
        if isinstance(grid, dict):
            grid = MediumGrid.from_dict(grid)
        if grid is not None and not isinstance(grid, MediumGrid):
            raise _err(f"grid = {grid!r}: give a subsurf.render.MediumGrid (or a table in a scene file)")
        self.grid = grid
        #: The surface maps (:class:`Texture`, set by :meth:`from_reflectance`): ``texture`` the
        #: colour map (or the mean-free-path map if only that is one), ``mfp_texture`` the
        #: mean-free-path map; σa, σs (mm⁻¹) and reflectance (per incident power) per texel.
        self.texture, self.mfp_texture = None, None
        self.texel_sigma_a, self.texel_sigma_s, self.texel_reflectance = None, None, None

    @property
    def layered(self) -> bool:
        return self.stacks is not None and any(
            len(s.layers) > 1 or math.isfinite(s.layers[0].thickness) for s in self.stacks
        )

    def channel_stacks(self):
        """One :class:`subsurf.Stack` per channel (the given ones, or a semi-infinite layer)."""
        if self.stacks is not None:
            return self.stacks
        return [Stack([Layer(self.eta, a, s, self.g)]) for a, s in zip(self.sigma_a, self.sigma_s)]

    @classmethod
    def library(cls, name, model="dipole", g=0.0, **kw):
        """A material of the Jensen et al. (2001) table (:mod:`subsurf.materials`); σs = σs'/(1 − g)."""
        m = _library(name)
        return cls(m.sigma_a, np.asarray(m.sigma_s_prime) / (1 - g), g=g, eta=m.eta, model=model, name=m.name, **kw)

    @classmethod
    def from_stacks(cls, stacks, model="monte_carlo", name=None, **kw):
        """A (possibly layered) material given as one :class:`subsurf.Stack` (or Layer) per channel.
        The medium seen by ``random_walk`` is the top layer (layered materials need nested meshes there)."""
        stacks = [s if isinstance(s, Stack) else Stack([s]) for s in stacks]
        top = [s.layers[0] for s in stacks]
        gs = {l.g for l in top}
        if len(gs) != 1 or len({l.n for l in top}) != 1:
            raise _err("stacks: the top layers of the three channels must share g and n")
        return cls(
            [l.mua for l in top],
            [l.mus for l in top],
            g=gs.pop(),
            eta=top[0].n / stacks[0].n_above,
            model=model,
            name=name,
            stacks=stacks,
            **kw,
        )

    @classmethod
    def from_reflectance(
        cls,
        reflectance,
        mfp,
        *,
        eta=1.3,
        g=0.0,
        model="dipole",
        power="incident",
        mfp_kind="extinction",
        name=None,
        table=None,
        **kw,
    ):
        """From a reflectance (∈ [0, 1]) and a mean free path (mm) per RGB channel, inverted under
        ``model`` by :func:`subsurf.bssrdf.material_from_reflectance` (same parameters: ``power``
        incident or entering, ``mfp_kind`` extinction, transport, diffuse or burley_d; ``table``
        the :class:`~subsurf.bssrdf.ProfileTable` of ``monte_carlo`` and ``normalized_diffusion``).
        A render of the material under ``model`` shows the reflectance (per incident power).
        ``reflectance`` and/or ``mfp`` may be a :class:`Texture` (a colour map, a mean-free-path
        map, scalar or RGB) on meshes with UVs, for every method and :func:`simulate_walk`: each
        texel inverted (docs/render.md, "Surface maps")."""
        from .. import bssrdf, diffusion

        if isinstance(reflectance, Texture) or isinstance(mfp, Texture):
            opts = dict(eta=eta, g=g, model=model, power=power, mfp_kind=mfp_kind, table=table)
            return cls._textured(reflectance, mfp, name=name, **opts, **kw)
        refl = _vec3("reflectance", reflectance)
        mfp = _vec3("mfp", mfp)
        layers = bssrdf.material_from_reflectance(
            refl, mfp, eta=eta, g=g, model=model, power=power, mfp_kind=mfp_kind, table=table
        )
        if power == "entering":  # stored per incident power: × F_t at normal incidence = 1 − R_sp
            refl = [r * float(diffusion.ft(eta, 1.0)) for r in refl]
        return cls(
            [l.mua for l in layers],
            [l.mus for l in layers],
            g=g,
            eta=eta,
            model=model,
            name=name,
            reflectance=refl,
            **kw,
        )

    @classmethod
    def _textured(cls, refl, mfp, *, eta, g, model, power, mfp_kind, name, table, **kw):
        """A material with a colour map and/or a mean-free-path map (:class:`Texture`; the other
        one a constant per channel): every texel inverted by
        :func:`subsurf.bssrdf.material_from_reflectance` at its mean free path (each distinct
        reflectance once, scaled per texel: :func:`~subsurf.render.media.invert_maps`). The
        material's own σa, σs are those of the maps' mean colour and mean free path."""
        from .. import bssrdf, diffusion

        if model == "adaptive":
            raise _err('model = "adaptive" takes no surface texture (its tables are built per material)')
        maps = {"reflectance": refl, "mfp": mfp}
        shapes = {k: v.shape for k, v in maps.items() if isinstance(v, Texture)}
        if len(set(shapes.values())) > 1:
            raise _err(
                f"mfp: the mean-free-path map has shape {shapes['mfp']} but the colour map {shapes['reflectance']}; "
                "give both maps at the same resolution (height, width)"
            )
        shape = (*next(iter(shapes.values())), 3)
        r = refl.reflectance if isinstance(refl, Texture) else np.broadcast_to(_vec3("reflectance", refl), shape)
        if isinstance(mfp, Texture):
            m_texel, mfp_ref = mfp.mfp, [1.0] * 3
        else:
            mfp_ref = _vec3("mfp", mfp)
            if not all(x > 0 for x in mfp_ref):
                raise _err(f"mfp = {mfp!r}: every mean free path must be > 0 (mm)")
            m_texel = np.broadcast_to(mfp_ref, shape)
        opts = dict(eta=eta, g=g, model=model, power=power, mfp_kind=mfp_kind, table=table)

        def invert(k, values, mfp_k):
            sa, ss = [], []
            for i in range(0, len(values), 3):
                v = [float(x) for x in values[i : i + 3]]
                v += [v[-1]] * (3 - len(v))
                try:
                    layers = bssrdf.material_from_reflectance(v, [mfp_k] * 3, **opts)
                except _core.ParameterError as e:
                    raise _err(f"texture, channel {k}: {e}") from None
                n = min(3, len(values) - i)
                sa += [l.mua for l in layers][:n]
                ss += [l.mus for l in layers][:n]
            return sa, ss

        sigma_a, sigma_s = invert_maps(np.asarray(r, dtype=np.float64), m_texel, invert, mfp_ref)
        mean = lambda v: v.mean() if isinstance(v, Texture) else v  # noqa: E731
        m = cls.from_reflectance(mean(refl), mean(mfp), name=name, **opts, **kw)
        m.texture = refl if isinstance(refl, Texture) else mfp
        m.mfp_texture = mfp if isinstance(mfp, Texture) else None
        m.texel_sigma_a, m.texel_sigma_s = sigma_a, sigma_s
        # Per incident power, as the untextured material stores it (normalized diffusion's albedo).
        ft0 = float(diffusion.ft(eta, 1.0)) if power == "entering" else 1.0
        m.texel_reflectance = np.ascontiguousarray(np.asarray(r, dtype=np.float64) * ft0)
        return m

    @classmethod
    def from_color(cls, color, mean_free_path, eta=1.3, g=0.0, model="dipole", name=None, table=None, **kw):
        """Deprecated forwarding alias, kept until the demo that calls it is merged:
        :meth:`from_reflectance` (per incident power, mean free path 1/σt)."""
        return cls.from_reflectance(color, mean_free_path, eta=eta, g=g, model=model, name=name, table=table, **kw)

    def _to_core(self, name, to_object=None):
        return {
            "grid": None if self.grid is None else self.grid._to_core(to_object),
            "texture": None
            if self.texel_sigma_s is None
            else {
                "sigma_a": np.ascontiguousarray(self.texel_sigma_a),
                "sigma_s": np.ascontiguousarray(self.texel_sigma_s),
                "reflectance": self.texel_reflectance,
            },
            "kind": "translucent",
            "name": name,
            "sigma_a": self.sigma_a,
            "sigma_s": self.sigma_s,
            "g": self.g,
            "eta": self.eta,
            "model": self.model,
            "stacks": [s._to_core() for s in self.channel_stacks()],
            "mc_photons": self.mc_photons,
            "mc_seed": self.mc_seed,
            "single_scattering": self.single_scattering,
            "reflectance": self.reflectance,
        }

    def adaptive_table(self, threads=None, progress=None):
        """The ``adaptive`` model's :class:`subsurf.bssrdf.AdaptiveTable` of this material (its
        channel stacks, ``mc_photons`` per node and ``mc_seed``), from the on-disk cache or built
        and cached (:meth:`subsurf.bssrdf.AdaptiveTable.cached`)."""
        from ..adaptive_table import AdaptiveTable

        key = (repr(self.channel_stacks()), self.mc_photons, self.mc_seed)
        if getattr(self, "_adaptive", (None,))[0] != key:  # kept while the material is unchanged
            t = AdaptiveTable.cached(
                self.channel_stacks(), photons=self.mc_photons, seed=self.mc_seed, threads=threads, progress=progress
            )
            self._adaptive = (key, t)
        return self._adaptive[1]

    def __repr__(self):
        return (
            f"Translucent(name={self.name!r}, sigma_a={self.sigma_a}, sigma_s={self.sigma_s}, g={self.g}, "
            f"eta={self.eta}, model={self.model!r}" + ("" if self.grid is None else f", grid={self.grid!r}") + ")"
        )


class Lambertian:
    """Opaque Lambertian reflector with ``albedo`` per channel in [0, 1]."""

    KEYS = ("albedo",)

    def __init__(self, albedo=0.8, name=None):
        self.albedo, self.name = _vec3("albedo", albedo), name

    def _to_core(self, name):
        return {"kind": "lambertian", "name": name, "albedo": self.albedo}


#: Material types of scene files (``type = "..."``).
MATERIAL_TYPES = ("translucent", "lambertian")


def _no_unknown(key, d, allowed):
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise _err(f"{key}: unknown keys {unknown} (allowed: {sorted(allowed)})")


def material(spec, key="material"):
    """A material from a library name, a Translucent/Lambertian, or a dict (TOML tables)."""
    if isinstance(spec, (Translucent, Lambertian)):
        return spec
    if isinstance(spec, str):
        try:
            return Translucent.library(spec)
        except _core.ParameterError as e:
            raise _err(f"{key}: {e}") from None
    if isinstance(spec, dict):
        d = dict(spec)
        kind = d.pop("type", "translucent")
        if kind not in MATERIAL_TYPES:
            raise _err(f"{key}.type = {kind!r}: must be one of {list(MATERIAL_TYPES)}")
        if kind == "lambertian":
            _no_unknown(key, d, Lambertian.KEYS)
        try:
            if kind == "lambertian":
                return Lambertian(d.get("albedo", 0.8))
            if "library" in d:
                lib = d.pop("library")
                return Translucent.library(lib, **d)
            if "reflectance" in d:
                return Translucent.from_reflectance(d.pop("reflectance"), d.pop("mfp"), **d)
            if "color" in d:  # deprecated spelling, kept until the demo that uses it is merged
                return Translucent.from_color(d.pop("color"), d.pop("mean_free_path"), **d)
            if not {"sigma_a", "sigma_s"} <= set(d):
                raise _err(f"{key}: give 'library', 'reflectance' and 'mfp', or 'sigma_a' and 'sigma_s'")
            return Translucent(**d)
        except TypeError as e:
            raise _err(f"{key}: {e}") from None
        except KeyError as e:
            raise _err(f"{key}: missing {e}") from None
        except _core.ParameterError as e:
            raise _err(f"{key}: {e}") from None
    raise _err(f"{key} = {spec!r}: give a library name, a table, or a Translucent/Lambertian")


# --- geometry ------------------------------------------------------------------------------


def _transform(positions, translate=None, scale=None, rotate=None):
    """Apply scale (number or 3), rotation (degrees about x, y, z, in that order), translation."""
    p = np.asarray(positions, dtype=np.float64)
    if scale is not None:
        p = p * np.asarray(_vec3("scale", scale))
    if rotate is not None:
        for axis, deg in enumerate(_vec3("rotate", rotate)):
            c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
            i, j = [(1, 2), (2, 0), (0, 1)][axis]
            pi, pj = p[:, i].copy(), p[:, j].copy()
            p[:, i], p[:, j] = c * pi - s * pj, s * pi + c * pj
    if translate is not None:
        p = p + np.asarray(_vec3("translate", translate))
    return p


class Object:
    """A mesh with a material. Use :meth:`mesh` (a file or a ``trimesh.Trimesh``) or the shape
    constructors :meth:`sphere`, :meth:`box`, :meth:`plane`, :meth:`torus`; ``translate``,
    ``scale``, ``rotate`` (degrees about x, y, z) transform it; ``tint`` (per-vertex RGB in
    [0, 1]) scales the light leaving a translucent surface."""

    def __init__(
        self, positions, triangles, material, name=None, tint=None, translate=None, scale=None, rotate=None, uv=None
    ):
        self.positions = _transform(positions, translate, scale, rotate)
        self._placement = (translate, scale, rotate)
        self.triangles = np.asarray(triangles, dtype=np.int64)
        self.material = material if isinstance(material, (Translucent, Lambertian)) else globals()["material"](material)
        self.name = name
        self.tint = None if tint is None else np.asarray(tint, dtype=np.float64)
        if self.tint is not None and self.tint.ndim != 2:
            raise _err(f"tint: expected an array of shape (n_vertices, 3), got shape {self.tint.shape}")
        self.uv = None if uv is None else np.asarray(uv, dtype=np.float64)
        if self.uv is not None and self.uv.shape == (len(self.positions), 2):
            self.uv = self.uv[self.triangles]  # per vertex → per triangle corner
        if self.uv is not None and self.uv.shape != (len(self.triangles), 3, 2):
            raise _err(
                f"uv: expected texture coordinates of shape (n_vertices, 2) or (n_triangles, 3, 2), got {self.uv.shape}"
            )

    @classmethod
    def mesh(cls, source, material, name=None, **kw):
        """From a mesh file (OBJ, PLY, STL, GLB; loaded with trimesh) or a ``trimesh.Trimesh``."""
        try:
            import trimesh
        except ImportError:
            raise _err(
                "loading meshes needs the 'trimesh' package (a dependency of subsurf): pip install trimesh"
            ) from None

        if isinstance(source, (str, os.PathLike)):
            path = os.fspath(source)
            if not os.path.exists(path):
                raise FileNotFoundError(f"{name or 'mesh'}: mesh file {path!r} does not exist")
            try:  # process=False: the core checks the vertices (a NaN is named, not dropped)
                tm = trimesh.load(path, force="mesh", process=False)
            except ImportError:  # trimesh guesses the encoding of undecodable text with an optional package
                raise _err(f"{name or path}: cannot read mesh file {path!r}: it is not a valid mesh file") from None
            except Exception as e:  # trimesh raises many kinds on malformed files
                raise _err(f"{name or path}: cannot read mesh file {path!r}: {e}") from None
            if isinstance(tm, trimesh.Trimesh) and len(tm.faces) == 0:
                raise _err(
                    f"{name or path}: cannot read mesh file {path!r}: it is not a valid mesh file (no faces found)"
                )
        else:
            tm = source
        if not isinstance(tm, trimesh.Trimesh):
            raise _err(f"{name or 'mesh'}: {type(tm).__name__} is not a triangle mesh")
        tint = kw.pop("tint", None)
        if tint is None and getattr(tm.visual, "kind", None) == "vertex":
            tint = np.asarray(tm.visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
        vertices, faces = np.asarray(tm.vertices), np.asarray(tm.faces)
        uv = kw.pop("uv", None)
        if uv is None and getattr(tm.visual, "uv", None) is not None and len(tm.visual.uv) == len(vertices):
            # Texture coordinates per corner; vertices split at UV seams are merged again by
            # position, so the mesh stays closed for the random walk.
            uv = np.asarray(tm.visual.uv, dtype=np.float64)[faces]
            vertices, inverse = np.unique(vertices, axis=0, return_inverse=True)
            faces = inverse.reshape(-1)[faces]
            tint = None if tint is None else np.asarray(tint)[np.unique(inverse.reshape(-1), return_index=True)[1]]
        return cls(vertices, faces, material, name=name, tint=tint, uv=uv, **kw)

    @classmethod
    def sphere(cls, material, center=(0, 0, 0), radius=1.0, subdivisions=4, name=None, **kw):
        p, t = _core.render_shape("sphere", _vec3("center", center), c=_float("radius", radius), level=subdivisions)
        return cls(p, t, material, name=name, **kw)

    @classmethod
    def box(cls, material, lo=(-1, -1, -1), hi=(1, 1, 1), name=None, **kw):
        p, t = _core.render_shape("box", _vec3("lo", lo), _vec3("hi", hi))
        return cls(p, t, material, name=name, **kw)

    @classmethod
    def plane(cls, material, center=(0, 0, 0), size=(10, 10), name=None, **kw):
        c, s = _vec3("center", center), _size2(size)
        p, t = _core.render_shape("plane", c, c=s[0], d=s[1])
        return cls(p, t, material, name=name, **kw)

    @classmethod
    def torus(cls, material, center=(0, 0, 0), major=2.0, minor=0.5, name=None, **kw):
        p, t = _core.render_shape("torus", _vec3("center", center), c=_float("major", major), d=_float("minor", minor))
        return cls(p, t, material, name=name, **kw)

    def info(self):
        """(closed, open_edges, area mm², volume mm³), validating the mesh."""
        return _core.render_mesh_info(self._mesh_dict(self.name or "mesh"))

    def _to_object(self):
        """The world → object affine map (3 rows of (A | b)) of this object's transform."""
        return to_object_map(lambda p: _transform(p, *self._placement))

    def _mesh_dict(self, name):
        d = {"name": name, "positions": self.positions, "triangles": self.triangles, "tint": self.tint}
        return d if self.uv is None else {**d, "uv": np.ascontiguousarray(self.uv)}


# --- lights and camera ------------------------------------------------------------------------


#: Light types and their parameters (the core's ``render::LightKind``).
LIGHT_PARAMS = {kind: tuple(params) for kind, params in _core.RENDER_LIGHTS.items()}


class _Light:
    """A light of type ``kind``: its parameters (:data:`LIGHT_PARAMS`) are its attributes."""

    kind = ""

    def _to_core(self, i):
        d = {"kind": self.kind}
        for p in LIGHT_PARAMS[self.kind]:
            v = getattr(self, p)
            d[p] = _float(f"lights[{i}].{p}", v) if p == "radius" else _vec3(f"lights[{i}].{p}", v)
        return d

    def __repr__(self):
        args = ", ".join(f"{p}={getattr(self, p)!r}" for p in LIGHT_PARAMS[self.kind])
        return f"{type(self).__name__}({args})"


class PointLight(_Light):
    """Isotropic point light at ``position`` of total ``power`` (W per channel)."""

    kind = "point"

    def __init__(self, position, power):
        self.position, self.power = position, power


class DirectionalLight(_Light):
    """Collimated light arriving from ``direction`` (towards the light) with ``irradiance`` W/mm²."""

    kind = "directional"

    def __init__(self, direction, irradiance):
        self.direction, self.irradiance = direction, irradiance


class SphereLight(_Light):
    """Spherical area light at ``position`` of ``radius`` (mm) and total ``power``."""

    kind = "sphere"

    def __init__(self, position, radius, power):
        self.position, self.radius, self.power = position, radius, power


class RectLight(_Light):
    """One-sided rectangle ``position`` ± ``u`` ± ``v`` (half-edge vectors), emitting along u × v."""

    kind = "rect"

    def __init__(self, position, u, v, power):
        self.position, self.u, self.v, self.power = position, u, v, power


#: The light classes, one per type of :data:`LIGHT_PARAMS`.
LIGHTS = (PointLight, DirectionalLight, SphereLight, RectLight)


class Camera:
    """Pinhole camera: ``position``, ``look_at``, ``up``, vertical ``fov`` (degrees), resolution."""

    def __init__(self, position, look_at=(0, 0, 0), up=(0, 0, 1), fov=30.0, width=256, height=256):
        self.position, self.look_at, self.up = position, look_at, up
        self.fov, self.width, self.height = _float("camera.fov", fov), width, height  # the core checks the sizes

    def _to_core(self):
        return {
            "position": _vec3("camera.position", self.position),
            "look_at": _vec3("camera.look_at", self.look_at),
            "up": _vec3("camera.up", self.up),
            "fov": self.fov,
            "width": self.width,
            "height": self.height,
        }


class Scene:
    """Objects, lights, a constant ``environment`` radiance (RGB) and a camera."""

    def __init__(self, objects=(), lights=(), environment=(0, 0, 0), camera=None):
        self.objects, self.lights = list(objects), list(lights)
        self.environment, self.camera = environment, camera

    def materials(self):
        mats = []
        for o in self.objects:
            if not any(o.material is m for m in mats):
                mats.append(o.material)
        return mats

    def _to_core(self, method=None):
        mats = self.materials()
        names = [m.name or f"material{i}" for i, m in enumerate(mats)]
        if method == "random_walk":
            for m, n in zip(mats, names):
                if isinstance(m, Translucent) and m.layered:
                    raise _err(
                        f"materials.{n}: random_walk cannot use a layered stack on one mesh; "
                        "model the layers as nested closed meshes"
                    )
        # One core material per material, or per (material, object) for a grid material: its
        # grid is in object space and follows each object's transform.
        objs, entries, index, tables = [], [], {}, {}
        for i, o in enumerate(self.objects):
            k = next(k for k, m in enumerate(mats) if m is o.material)
            key = (k, i) if getattr(o.material, "grid", None) is not None else (k, None)
            if key not in index:
                index[key] = len(entries)
                m = o.material
                core = m._to_core(names[k], o._to_object()) if key[1] is not None else m._to_core(names[k])
                if method != "random_walk" and isinstance(m, Translucent) and m.model == "adaptive":
                    if k not in tables:  # the adaptive model's tables, from the on-disk cache
                        tables[k] = m.adaptive_table()._t
                    core["adaptive_table"] = tables[k]
                entries.append(core)
            objs.append({"mesh": o._mesh_dict(o.name or f"objects[{i}]"), "material": index[key]})
        return {
            "objects": objs,
            "materials": entries,
            "lights": [l._to_core(i) for i, l in enumerate(self.lights)],
            "environment": _vec3("environment", self.environment),
            "camera": None if self.camera is None else self.camera._to_core(),
        }
