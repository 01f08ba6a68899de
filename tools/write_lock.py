"""Print requirements.lock: every installed distribution but armcal at its exact version (``bash tasks.sh lock``).

A distribution that installed packages require only on some machines (``embreex; platform_machine != "aarch64"``)
keeps that machine condition, so one lock installs on x86_64 and aarch64 alike; one that any of them requires
without such a condition is pinned for every machine.
"""

from __future__ import annotations

import re
import sys
from importlib.metadata import distributions

MACHINE_CONDITION = re.compile(r"\b(platform_machine|sys_platform|platform_system|os_name)\b")
EXTRA_CLAUSE = re.compile(r"\s*(?:and\s+)?extra\s*==\s*['\"][^'\"]*['\"]|\s*(?:and\s+)?\(extra\s*==\s*['\"][^'\"]*['\"]\)")


def _key(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def main() -> None:
    installed = {_key(d.metadata["Name"]): d for d in distributions()}
    conditions: dict[str, set[str]] = {}
    everywhere: set[str] = set()
    for dist in installed.values():
        for requirement in dist.requires or []:
            name, _, marker = requirement.partition(";")
            required = _key(re.split(r"[\s\[<>=!~(]", name.strip(), maxsplit=1)[0])
            if required not in installed:
                continue
            if MACHINE_CONDITION.search(marker):
                conditions.setdefault(required, set()).add(EXTRA_CLAUSE.sub("", marker).strip().removeprefix("and ").strip())
            else:
                everywhere.add(required)
    lines = []
    for key, dist in installed.items():
        if key == "armcal":
            continue
        pin = f"{dist.metadata['Name']}=={dist.version}"
        machines = sorted(conditions.get(key, ())) if key not in everywhere else []
        lines.append(f"{pin}; " + " or ".join(f"({m})" if len(machines) > 1 else m for m in machines) if machines else pin)
    sys.stdout.write("".join(line + "\n" for line in sorted(lines, key=str.lower)))


if __name__ == "__main__":
    main()
