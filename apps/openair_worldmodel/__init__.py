"""A distributed blackboard world model riding on OpenAIR whiteboards (spec section 16).

The sans-I/O core: `packets` (attribute packets and their last-writer-wins order), `blackboard`
(objects, class tree, active functions), `conditions` (the condition language), `plans` (the
plan engine), `wire` (the `WM.` message contents) and `interface` (`WorldModelCore`). The asyncio
adapter over the Python client is `node.WorldModelNode`.
"""

from __future__ import annotations

from openair_worldmodel.blackboard import Blackboard, ClassDef, FunctionRef, WMObject
from openair_worldmodel.conditions import parse_condition, to_text
from openair_worldmodel.interface import Outgoing, ReportFilter, WorldModelCore
from openair_worldmodel.packets import Context, Packet, Ref
from openair_worldmodel.plans import Ack, ControlAction, Fire, Plan, PlanEngine, ReportAction

__all__ = [
    "Ack",
    "Blackboard",
    "ClassDef",
    "Context",
    "ControlAction",
    "Fire",
    "FunctionRef",
    "Outgoing",
    "Packet",
    "Plan",
    "PlanEngine",
    "Ref",
    "ReportAction",
    "ReportFilter",
    "WMObject",
    "WorldModelCore",
    "parse_condition",
    "to_text",
]
