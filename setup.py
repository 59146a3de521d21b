"""Build the optional C extension of the server's data path (issue #20).

Everything else is declared in pyproject.toml. `optional=True`: without a working compiler the
build goes on and the wheel holds the pure-Python data path only.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "openair.server.aio.datapath._native",
            sources=["reference/openair/server/aio/datapath/_native.c"],
            optional=True,
        )
    ]
)
