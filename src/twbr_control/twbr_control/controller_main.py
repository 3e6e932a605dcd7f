"""controller_node's executable: the node with its cores interpreted unless TWBR_JIT=on (twbr_common.deploy)."""

from __future__ import annotations

from twbr_common.deploy import run_interpreted


def main(args: list[str] | None = None) -> int:
    return run_interpreted("twbr_control.controller_node", args)
