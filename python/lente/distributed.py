"""Renders spread over a Dask cluster.

lente's sample streams are deterministic: samples ``s0..s1`` of every pixel
are the same samples whichever process renders them. A render is split into
sample ranges, each range is one Dask task that returns its film state, and
the films are added in range order, so the image does not depend on which
worker did what, on how many there were, or on a worker that died and had
its task run again by Dask.

    >>> from dask.distributed import Client
    >>> client = Client("tcp://scheduler:8786")      # or Client() locally
    >>> import lente.distributed
    >>> image = lente.distributed.render("scene.xml", spp=1024, client=client)

Every worker needs lente installed (``pip install .``) and the scene file
(and what it names: meshes, textures, probes) at the same path, e.g. on a
shared file system.

Why Dask rather than Ray: it is pure Python on PyPI (``pip install
"dask[distributed]"``), runs the same on a laptop (``LocalCluster``), an SSH
cluster, Kubernetes and HPC schedulers (dask-jobqueue for Slurm, PBS, SGE),
and its scheduler already does what this needs: it re-runs the tasks of a
worker that dies (up to ``distributed.scheduler.allowed-failures`` times)
and keeps results in worker memory until gathered.
"""

from __future__ import annotations

import functools
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

from . import Image, load, merge, stack, write

__all__ = ["render", "sample_ranges", "row_strips"]


def sample_ranges(spp: int, tasks: int) -> List[Tuple[int, int]]:
    """``spp`` samples cut into ``tasks`` contiguous ranges (as even as
    possible; never an empty one)."""
    if spp < 1:
        raise ValueError("spp must be at least 1")
    tasks = max(1, min(int(tasks), spp))
    bounds = [spp * i // tasks for i in range(tasks + 1)]
    return [(bounds[i], bounds[i + 1]) for i in range(tasks)]


def row_strips(height: int, strips: int) -> List[Tuple[int, int]]:
    """``height`` rows cut into ``strips`` contiguous strips."""
    return sample_ranges(height, strips)


@functools.lru_cache(maxsize=4)
def _scene(path: str, params: Tuple[Tuple[str, Any], ...]) -> Any:
    # Loaded once per worker process and scene (the BVH build is not free).
    return load(path, **dict(params))


def _render_range(
    path: str,
    params: Tuple[Tuple[str, Any], ...],
    s0: int,
    s1: int,
    seed: int,
    threads: Optional[int],
    aovs: str,
    rows: Optional[Tuple[int, int]] = None,
) -> Dict[str, Any]:
    film = _scene(path, params).render_film(
        samples=(s0, s1), seed=seed, threads=threads, aovs=aovs, progress=False, rows=rows
    )
    # The normalised image and AOVs are rebuilt after the merge.
    return {k: film[k] for k in ("sums", "weights", "aov_sums", "spp", "seconds")}


def render(
    scene_path: Union[str, "os.PathLike[str]"],
    spp: Optional[int] = None,
    *,
    params: Optional[Dict[str, Any]] = None,
    seed: int = 0,
    tasks: Optional[int] = None,
    strips: int = 1,
    threads_per_task: Optional[int] = None,
    aovs: Optional[Union[str, Sequence[str]]] = None,
    client: Any = None,
    output: Optional[Union[str, "os.PathLike[str]"]] = None,
    retries: int = 2,
) -> Image:
    """Renders ``scene_path`` on a Dask cluster and returns the image (and
    writes it to ``output``, EXR/PNG by extension, if given).

    spp: samples per pixel (default: the scene's). tasks: sample ranges to
    cut the render into (default: two per worker thread of the cluster, at
    most spp). strips: also cut the image into this many strips of rows,
    each task holding only its strip's film (for images too large for one
    worker's memory); the strips are bit for bit rows of the whole image. threads_per_task: threads each task renders with (default:
    all the worker's cores). client: a ``dask.distributed.Client``
    (default: the current one). retries: extra attempts for a task that
    raises; a task whose worker dies is re-run by the scheduler anyway.
    """
    from dask.distributed import get_client

    path = os.path.abspath(os.fspath(scene_path))
    params_key = tuple(sorted((params or {}).items()))
    if spp is None:
        spp = _scene(path, params_key).spp
    if client is None:
        client = get_client()
    if tasks is None:
        threads = sum(client.nthreads().values()) or 1
        tasks = 2 * threads
    aov_text = aovs if isinstance(aovs, str) or aovs is None else ",".join(aovs)
    ranges = sample_ranges(int(spp), tasks)
    if strips > 1:
        height = _scene(path, params_key).height
        row_ranges: List[Optional[Tuple[int, int]]] = list(row_strips(height, strips))
    else:
        row_ranges = [None]
    tag = f"{os.path.basename(path)}-{seed}-{os.getpid()}-{id(ranges)}"
    futures = [
        [
            client.submit(
                _render_range,
                path,
                params_key,
                s0,
                s1,
                int(seed),
                threads_per_task,
                aov_text or "",
                rows,
                key=f"lente-{tag}-{s0}-{s1}-{rows}",
                pure=False,
                retries=retries,
            )
            for s0, s1 in ranges
        ]
        for rows in row_ranges
    ]
    # Strip by strip: only one strip's films are here at a time.
    parts = [merge(client.gather(strip)) for strip in futures]
    image = parts[0] if len(parts) == 1 else stack(parts)
    if output is not None:
        write(output, image)
    return image
