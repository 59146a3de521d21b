"""Shared test configuration: hypothesis profiles (dev / ci / soak) and common markers.

Select a profile with HYPOTHESIS_PROFILE; CI (CI=true) defaults to `ci`. `make fuzz` uses `soak`.
"""

from __future__ import annotations

import os
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "dev", max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "ci",
    max_examples=100,
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "soak", max_examples=20_000, deadline=None, suppress_health_check=list(HealthCheck)
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


#: Test folders whose files share one expensive session fixture and must not run in two worker
#: processes at once: the three-node cluster (two clusters side by side on two cores made the
#: fault tests' timing fragile).
ONE_WORKER_FOLDERS = ("tests/cluster/",)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """`--dist loadfile` (make test), with each of ONE_WORKER_FOLDERS one unit of work."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class _FolderOrFile(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            folder = next((f for f in ONE_WORKER_FOLDERS if nodeid.startswith(f)), None)
            return folder if folder is not None else str(super()._split_scope(nodeid))

    return _FolderOrFile(config, log)
