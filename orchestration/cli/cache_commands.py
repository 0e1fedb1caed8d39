"""``sotc-cosim cache``: this user's private caches (``orchestration.verified``), listed with their sizes, or
cleared."""
from __future__ import annotations

import argparse
import time

from orchestration import exit_codes


def _mib(size: int) -> str:
    return f"{size / 2**20:,.1f} MiB"


def _cmd_cache(args: argparse.Namespace) -> int:
    from orchestration import verified
    from orchestration.outputs import private_root

    bound = verified.limit()
    if args.action == "clear":
        removed, kept = verified.clear()
        print(f"removed {len(removed)} cache entr{'y' if len(removed) == 1 else 'ies'} "
              f"({_mib(sum(e.size for e in removed))})"
              + (f"; kept {len(kept)} in use: {', '.join(str(e.path) for e in kept)}" if kept else ""))
        return exit_codes.OK
    found = sorted(verified.entries(), key=lambda e: e.used)
    print(f"caches under {private_root()} (limit {_mib(bound)}, {verified.LIMIT_VARIABLE}; least recently used first)")
    for e in found:
        used = time.strftime("%Y-%m-%d %H:%M", time.localtime(e.used))
        print(f"  {e.kind:<22} {e.path.name[:12]}  {_mib(e.size):>12}  used {used}")
    for kind in verified.KINDS:
        mine = [e for e in found if e.kind == kind]
        print(f"{kind:<24} {len(mine):>4} entries {_mib(sum(e.size for e in mine)):>12}")
    print(f"{'total':<24} {len(found):>4} entries {_mib(sum(e.size for e in found)):>12}")
    return exit_codes.OK


def add_commands(sub) -> None:
    """cache."""
    p = sub.add_parser("cache", help="list this user's private caches (compiled cores, unpacked FMUs) with their "
                                     "sizes, or clear them")
    p.add_argument("action", nargs="?", choices=("list", "clear"), default="list",
                   help="list (default): each entry and the sizes; clear: remove every entry not in use")
    p.set_defaults(func=_cmd_cache)
