"""planner_node's executable: the node with its cores compiled unless TWBR_JIT=off.

Unlike the controller (twbr_common.deploy), the planner compiles by default: the robust method's yielding
rolls out ~130 candidate commands over 5 s when something comes its way, 88 ms p99 interpreted against its
50 ms period (under 1 ms compiled). The kernels load from the on-disk cache (~1 s); the first start after a
change of the sources compiles them (~25 s on 2 cores) and says so.
"""

from __future__ import annotations

from twbr_planner.planner_node import main as node_main


def main(args: list[str] | None = None) -> int:
    return node_main(args)
