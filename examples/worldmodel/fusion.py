"""The fusion module: an on-write active function places the obstacle in absolute x/y."""

from __future__ import annotations

import asyncio

from wm_common import FUSING_OBSTACLE, ROBOT, WHITEBOARD, arguments, locate

from openair_worldmodel.node import WorldModelNode


async def run(host: str, port: int, stop: asyncio.Event | None = None) -> None:
    """Serve until `stop` is set (or forever): reports of range/bearing run `locate`."""
    async with WorldModelNode(
        "Fusion", robot=ROBOT, whiteboard=WHITEBOARD, host=host, port=port
    ) as node:
        node.core.blackboard.register_function("locate", locate)
        await node.define(FUSING_OBSTACLE)
        print("ready", flush=True)
        await (stop or asyncio.Event()).wait()


if __name__ == "__main__":
    args = arguments(__doc__ or "")
    asyncio.run(run(args.host, args.port))
