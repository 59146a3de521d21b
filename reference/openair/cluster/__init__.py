"""A cluster of OpenAIR servers whose whiteboards live in NATS JetStream (spec 17, issue #22).

`openair serve --cluster nats://HOST:PORT[,...] --node NAME` makes the server a node: every
node is the whole reference server, with a store (`ClusterStore`) that publishes posts to
JetStream and hands the posts other nodes stored back to the router. nats-py is the optional
extra `cluster` (`pip install 'openair-kit[cluster]'`).
"""

from __future__ import annotations

from openair.server.core.store import StoreSpecError

__all__ = ["open_cluster_store"]


def open_cluster_store(spec: str) -> object:
    """Return an unconnected ClusterStore for `NODE@nats://HOST:PORT[,...]`.

    Raises StoreSpecError for a bad address and when nats-py is not installed (one line).
    """
    try:
        import nats  # noqa: F401  (checked here so the error is one line, not a traceback)
    except ModuleNotFoundError:
        raise StoreSpecError(
            "a cluster node needs nats-py, which is not installed: "
            "pip install 'openair-kit[cluster]'"
        ) from None
    from openair.cluster.store import ClusterStore, parse_spec

    return ClusterStore(parse_spec(spec))
