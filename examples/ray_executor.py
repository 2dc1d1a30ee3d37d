"""A Ray executor for vfs studies: ``--engine ray`` on a Ray cluster.

vfs runs the tasks of a study through an *executor*, a function
``executor(tasks, on_result, options)`` (:mod:`vfs.study.executors`).  This
file implements one for Ray (https://www.ray.io) and registers it as ``ray``;
Ray is not a dependency of vfs, so the file stays importable without it and
only ``run_ray`` asks for it.

Run a study with it (the arguments are those of ``vfs study``; ``--scheduler``
is the Ray address, without it a local Ray instance with ``--workers`` CPUs is
started)::

    pip install "ray[default]"
    python examples/ray_executor.py --db default --systems three-stage \\
        --out results/ray-study --engine ray [--scheduler ray://head:10001]

or from Python: ``import ray_executor`` and then
``vfs.study.run_study(..., engine="ray")``.  To offer ``--engine ray`` to the
``vfs`` command itself, put ``run_ray`` into an installed package and declare
it in that package's ``pyproject.toml``::

    [project.entry-points."vfs.executors"]
    ray = "my_package.ray_executor:run_ray"

Every Ray worker needs vfs (and numpy) of the client's version: the executor
asks one worker before it starts (a Ray runtime environment with
``pip: ["vfs==..."]`` is one way to make sure every worker has it).  The
database must be reachable from the workers: ``--db default`` (each worker
uses its own bundled copy), a shared folder or an fsspec URL such as
``s3://bucket/db``.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from vfs.errors import ClusterError, ParameterError
from vfs.study import ExecutorOptions, RunTask, register_executor, run_task
from vfs.study.executors import OnResult, worker_versions

try:
    import ray
except ImportError:  # Ray is optional: run_ray says how to install it
    ray = None


def run_ray(tasks: Sequence[RunTask], on_result: OnResult, options: ExecutorOptions) -> None:
    """Run the study's tasks on Ray; ``on_result(task, table)`` here, in this thread.

    At most ``options.max_in_flight(CPUs of the cluster)`` tasks are
    submitted at a time, and each result's object reference is dropped as
    soon as ``on_result`` has it, so Ray frees it from its object store.
    """
    if ray is None:
        raise ParameterError("engine 'ray' needs Ray: pip install 'ray[default]'")
    started_here = not ray.is_initialized()
    if started_here:
        if options.scheduler:
            ray.init(address=options.scheduler)
        else:
            ray.init(num_cpus=options.workers)
    try:
        theirs = ray.get(ray.remote(worker_versions).remote())
        if theirs != worker_versions():
            raise ClusterError(f"a Ray worker runs {theirs}, the client {worker_versions()}; "
                               "install the same vfs and numpy on every worker")
        remote_run = ray.remote(run_task)
        cpus = int(ray.cluster_resources().get("CPU", options.workers))
        limit = options.max_in_flight(cpus)
        queue = iter(tasks)
        pending: dict[Any, RunTask] = {}

        def fill() -> None:
            while len(pending) < limit:
                task = next(queue, None)
                if task is None:
                    return
                pending[remote_run.remote(task)] = task

        fill()
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            ref = ready[0]
            task = pending.pop(ref)
            table = ray.get(ref)
            del ready, ref  # the last reference: Ray frees the result
            on_result(task, table)
            del table
            fill()
    finally:
        if started_here:
            ray.shutdown()


register_executor("ray", run_ray, replace=True)


if __name__ == "__main__":
    from vfs.cli import main

    sys.exit(main(["study", *sys.argv[1:]]))
