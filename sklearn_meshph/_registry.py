"""Registries of the option families: one list that estimators, the command line and
the documentation all read, so that adding an option is one entry."""

from __future__ import annotations

import re
import warnings
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
    in the command line's help and the documentation's tables. ``aliases`` maps former
    names to current ones: looking one up works, with a ``FutureWarning``; they are not
    listed among the names.
    """

    def __init__(self, family: str, options: list[Option], aliases: dict | None = None):
        self.family = family
        self._options = {o.name: o for o in options}
        self.aliases = dict(aliases or {})

    def __getitem__(self, name: str) -> Option:
        if name in self.aliases:
            warnings.warn(
                f"the {self.family} {name!r} is renamed {self.aliases[name]!r}; the former "
                "name will be removed in a future release",
                FutureWarning,
                stacklevel=2,
            )
            name = self.aliases[name]
        try:
            return self._options[name]
        except KeyError:
            raise ValueError(f"{self.family} must be one of {self.names}, got {name!r}") from None

    def __contains__(self, name) -> bool:
        return name in self._options

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


_BLOCK = re.compile(r"(<!-- registry: (\w+) -->\n)(.*?)(<!-- /registry -->)", re.DOTALL)


def update_tables(text: str, registries: Mapping[str, Registry]) -> str:
    """``text`` with every ``<!-- registry: family -->`` block replaced by the table of
    ``registries[family]``.

    ``python docs/update_tables.py`` applies it to the documentation, with every
    registry of the package (:func:`sklearn_meshph.pipelines.all_registries`); a test
    checks that the tables there are up to date.
    """

    def replace(match):
        return match.group(1) + registries[match.group(2)].table() + "\n" + match.group(4)

    return _BLOCK.sub(replace, text)
