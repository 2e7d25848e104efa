"""Registries of the option families: one list that estimators, the command line and
the documentation all read, so that adding an option is one entry."""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["Option", "Registry"]


@dataclass(frozen=True)
class Option:
    """One choice of a family: its name, its implementation and a one-line summary."""

    name: str
    value: Any
    summary: str


class Registry(Mapping):
    """An ordered, read-only mapping from option names to :class:`Option`.

    ``family`` names the parameter (``"laplacian"``, ``"filtration"``, ``"metric"``...)
    in the command line's help and the documentation's tables.
    """

    def __init__(self, family: str, options: list[Option]):
        self.family = family
        self._options = {o.name: o for o in options}

    def __getitem__(self, name: str) -> Option:
        try:
            return self._options[name]
        except KeyError:
            raise ValueError(f"{self.family} must be one of {self.names}, got {name!r}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._options)

    def __len__(self) -> int:
        return len(self._options)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self._options)

    def help(self) -> str:
        """The choices as one paragraph, for a command line's ``--help``."""
        return "; ".join(f"{o.name!r}: {o.summary}" for o in self._options.values())

    def table(self) -> str:
        """The choices as a Markdown table, as the documentation shows them."""
        rows = [f"| `{self.family}` | what it is |", "|---|---|"]
        rows += [f'| `"{o.name}"` | {o.summary} |' for o in self._options.values()]
        return "\n".join(rows)


def all_registries() -> dict[str, Registry]:
    """Every option family, by name: what the documentation's tables are made from."""
    from .diagrams.distances import METRICS
    from .persistence.filtrations import FILTRATIONS
    from .pipelines import PRESETS
    from .spectral.factorization import SOLVERS
    from .spectral.laplacians import LAPLACIANS
    from .spectral.signatures import SIGNATURES

    return {r.family: r for r in (LAPLACIANS, SOLVERS, SIGNATURES, FILTRATIONS, METRICS, PRESETS)}


_BLOCK = re.compile(r"(<!-- registry: (\w+) -->\n)(.*?)(<!-- /registry -->)", re.DOTALL)


def update_tables(text: str, registries: Mapping[str, Registry] | None = None) -> str:
    """``text`` with every ``<!-- registry: family -->`` block replaced by its table.

    ``python docs/update_tables.py`` applies it to the documentation; a test checks that
    the tables there are up to date.
    """
    registries = all_registries() if registries is None else registries

    def replace(match):
        return match.group(1) + registries[match.group(2)].table() + "\n" + match.group(4)

    return _BLOCK.sub(replace, text)
