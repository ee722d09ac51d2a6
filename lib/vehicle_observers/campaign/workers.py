"""Dask plug-ins of the campaign workers (imported only when the Dask engine runs)."""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin

from vehicle_observers.campaign import tasks


class CampaignPlugin(WorkerPlugin):
    """On every worker (also one that joins or restarts later): pin the thread counts of the
    pools started afterwards (:func:`tasks.pin_threads`), import the spec's plug-ins and warm
    the numba cache once (:func:`tasks.warm_up`)."""

    idempotent = True

    def __init__(self, plugins=()):
        self.plugins = tuple(plugins)
        self.name = f"vehicle-observers-campaign-{'-'.join(self.plugins) or 'builtin'}"

    def setup(self, worker):
        tasks.pin_threads()
        tasks.warm_up(self.plugins)


def thread_env() -> dict:
    """The worker's values of :data:`tasks.THREAD_ENV` (``client.run`` probe)."""
    import os

    return {k: os.environ.get(k) for k in tasks.THREAD_ENV}
