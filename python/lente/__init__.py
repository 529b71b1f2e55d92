"""lente: a physically based path tracer for Nori and Mitsuba 3 scenes.

    >>> import lente
    >>> scene = lente.load("scenes/mitsuba/cbox.xml", res=128)
    >>> image = scene.render(spp=64, seed=0)      # H x W x 3 float32 (numpy)
    >>> lente.write("cbox.exr", image)

Renders release the GIL, show a progress bar (tqdm, in terminals and
notebooks, when it is installed) and stop cleanly on Ctrl-C
(``KeyboardInterrupt``). Images are numpy arrays that Jupyter shows inline.
Samples ``s0..s1`` of every pixel (``samples=(s0, s1)``) are the same
whichever process renders them, so slices merge exactly into the whole
render: see :mod:`lente.distributed`.
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any, Callable, Dict, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lente
from ._lente import RenderError, SceneError

__all__ = [
    "Image",
    "RenderError",
    "Scene",
    "SceneError",
    "SceneWarning",
    "load",
    "read",
    "write",
    "merge",
    "stack",
    "__version__",
]

__version__: str = _lente.__version__

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[bool, Callable[[int, int], Any], None]


class SceneWarning(UserWarning):
    """Something in a scene file lente read but warns about (file:line:col)."""


class Image(np.ndarray):
    """A linear H x W x 3 float32 image: a numpy array, shown inline by
    Jupyter (sRGB, clamped), with the render's output variables in ``aovs``
    (channel name -> H x W array), its ``spp`` and ``seconds``."""

    aovs: Dict[str, np.ndarray]
    spp: Optional[int]
    seconds: Optional[float]

    def __new__(
        cls,
        array: Any,
        aovs: Optional[Dict[str, np.ndarray]] = None,
        spp: Optional[int] = None,
        seconds: Optional[float] = None,
    ) -> "Image":
        obj = np.asarray(array, dtype=np.float32).view(cls)
        obj.aovs = dict(aovs or {})
        obj.spp = spp
        obj.seconds = seconds
        return obj

    def __array_finalize__(self, obj: Any) -> None:
        self.aovs = getattr(obj, "aovs", {})
        self.spp = getattr(obj, "spp", None)
        self.seconds = getattr(obj, "seconds", None)

    def _repr_png_(self) -> Optional[bytes]:
        if self.ndim != 3 or self.shape[2] != 3 or self.size == 0:
            return None
        return bytes(_lente.png_bytes(np.ascontiguousarray(self, dtype=np.float32)))

    def write(self, path: PathLike) -> None:
        """Writes the image (EXR, HDR, PFM or PNG, by extension)."""
        write(path, self)


def _param_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return ", ".join(_param_text(v) for v in value)
    return str(value)


class Scene:
    """A loaded scene (see :func:`load`)."""

    def __init__(self, native: "_lente.NativeScene") -> None:
        self._native = native

    @property
    def width(self) -> int:
        return self._native.width

    @property
    def height(self) -> int:
        return self._native.height

    @property
    def spp(self) -> int:
        """The scene's own samples per pixel."""
        return self._native.spp

    @property
    def path(self) -> str:
        return str(self._native.path)

    @property
    def params(self) -> Dict[str, str]:
        return dict(self._native.params)

    def __repr__(self) -> str:
        return f"<lente.Scene {self.path!r} {self.width}x{self.height}, {self.spp} spp>"

    def render(
        self,
        spp: Optional[int] = None,
        seed: int = 0,
        threads: Optional[int] = None,
        samples: Optional[Tuple[int, int]] = None,
        aovs: Optional[Union[str, Sequence[str]]] = None,
        progress: Progress = True,
        rows: Optional[Tuple[int, int]] = None,
    ) -> Image:
        """Renders the scene and returns the image.

        spp: samples per pixel (default: the scene's). samples=(s0, s1):
        only those samples of every pixel (instead of spp). seed: the
        random streams (renders with different seeds are independent).
        threads: worker threads (default: all cores). aovs: output
        variables, e.g. ``["albedo", "normal"]`` or Mitsuba's
        ``"dd:depth,nn:sh_normal"``, returned in ``image.aovs``.
        progress: True for a bar (tqdm if installed), False for none, or a
        callable ``f(spp_done, spp_total)``. rows=(y0, y1): only those rows
        (a strip, bit for bit those rows of the whole image).
        """
        film = self.render_film(spp, seed, threads, samples, aovs, progress, rows)
        return Image(film["image"], film["aovs"], film["spp"], film["seconds"])

    def render_film(
        self,
        spp: Optional[int] = None,
        seed: int = 0,
        threads: Optional[int] = None,
        samples: Optional[Tuple[int, int]] = None,
        aovs: Optional[Union[str, Sequence[str]]] = None,
        progress: Progress = False,
        rows: Optional[Tuple[int, int]] = None,
    ) -> Dict[str, Any]:
        """Like :meth:`render`, but returns the film state that merges
        exactly (:func:`merge`): a dict with ``sums`` (H x W x 3),
        ``weights`` (H x W), ``aov_sums``, and ``image``, ``aovs``, ``spp``,
        ``seconds``."""
        if samples is not None:
            if spp is not None:
                raise ValueError("give spp or samples, not both")
            s0, s1 = (int(v) for v in samples)
            if s0 < 0 or s1 <= s0:
                raise ValueError(f"samples {s0}..{s1}: need 0 <= s0 < s1")
        else:
            s0, s1 = 0, int(spp if spp is not None else self.spp)
            if s1 < 1:
                raise ValueError("spp must be at least 1")
        if isinstance(aovs, str) or aovs is None:
            aov_text = aovs or ""
        else:
            aov_text = ",".join(aovs)
        with _progress_reporter(progress, s0, s1) as report:
            return self._native.render(
                s0, s1, int(seed), threads, aov_text, report,
                None if rows is None else (int(rows[0]), int(rows[1])),
            )


class _NoProgress:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: Any) -> None:
        return None


class _BarProgress:
    """tqdm's bar (its notebook widget in Jupyter), or a plain line on a
    terminal when tqdm is not installed."""

    def __init__(self, s0: int, s1: int) -> None:
        self.s0, self.s1 = s0, s1
        self.bar: Any = None
        self.plain = False

    def __enter__(self) -> Callable[[int, int], None]:
        try:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=self.s1 - self.s0, unit="spp", desc="lente")
        except ImportError:
            self.plain = sys.stderr.isatty()
        return self.update

    def update(self, done: int, total: int) -> None:
        if self.bar is not None:
            self.bar.update(done - self.s0 - self.bar.n)
        elif self.plain:
            sys.stderr.write(f"\rlente: {done}/{total} spp")
            sys.stderr.flush()

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.plain:
            sys.stderr.write("\n")


class _CallbackProgress:
    def __init__(self, f: Callable[[int, int], Any]) -> None:
        self.f = f

    def __enter__(self) -> Callable[[int, int], Any]:
        return self.f

    def __exit__(self, *exc: Any) -> None:
        return None


def _progress_reporter(progress: Progress, s0: int, s1: int) -> Any:
    if progress is True:
        return _BarProgress(s0, s1)
    if callable(progress):
        return _CallbackProgress(progress)
    return _NoProgress()


def load(path: PathLike, **params: Any) -> Scene:
    """Loads a Nori or Mitsuba 3 scene file (the dialect is detected).

    Keyword arguments set Mitsuba ``$name`` parameters (as ``-D name=value``
    does on the command line). Errors raise :class:`SceneError` with
    lente's ``file:line:col`` message; warnings become :class:`SceneWarning`.
    """
    native = _lente.load(
        os.fspath(path), [(k, _param_text(v)) for k, v in params.items()]
    )
    for w in native.warnings:
        warnings.warn(w, SceneWarning, stacklevel=2)
    return Scene(native)


def write(path: PathLike, image: Any) -> None:
    """Writes an H x W x 3 (or H x W) float array as EXR, HDR, PFM or PNG
    (by extension; PNG is sRGB-encoded and clamped), atomically."""
    _lente.write(os.fspath(path), np.ascontiguousarray(image, dtype=np.float32))


def read(path: PathLike) -> Image:
    """Reads an EXR, HDR, PFM or PNG as a linear H x W x 3 image."""
    return Image(_lente.read(os.fspath(path)))


def stack(strips: Sequence["Image"]) -> Image:
    """Strips of one render (``rows=`` from top to bottom) as one image."""
    if not strips:
        raise ValueError("nothing to stack")
    image = np.concatenate([np.asarray(s) for s in strips], axis=0)
    aovs = {k: np.concatenate([s.aovs[k] for s in strips], axis=0) for k in strips[0].aovs}
    return Image(image, aovs, strips[0].spp, sum(s.seconds or 0.0 for s in strips))


def merge(films: Iterable[Dict[str, Any]]) -> Image:
    """The image of several :meth:`Scene.render_film` results of one scene
    (different seeds, or disjoint sample slices): their films add up, in
    the order given."""
    films = list(films)
    if not films:
        raise ValueError("nothing to merge")
    sums = np.zeros_like(films[0]["sums"], dtype=np.float32)
    weights = np.zeros_like(films[0]["weights"], dtype=np.float32)
    aov_sums = {k: np.zeros_like(v, dtype=np.float32) for k, v in films[0]["aov_sums"].items()}
    for f in films:
        if f["sums"].shape != sums.shape or set(f["aov_sums"]) != set(aov_sums):
            raise ValueError("films of different sizes or AOVs do not merge")
        sums += f["sums"]
        weights += f["weights"]
        for k in aov_sums:
            aov_sums[k] += f["aov_sums"][k]
    safe = np.where(weights != 0, weights, np.float32(1))
    image = np.where(weights[..., None] != 0, sums / safe[..., None], np.float32(0))
    aovs = {k: np.where(weights != 0, v / safe, np.float32(0)) for k, v in aov_sums.items()}
    return Image(
        image.astype(np.float32),
        {k: v.astype(np.float32) for k, v in aovs.items()},
        sum(int(f["spp"]) for f in films),
        sum(float(f["seconds"]) for f in films),
    )
