"""The one YAML loader of the project's configuration files (no rclpy).

Differences from ``yaml.safe_load`` (PyYAML follows YAML 1.1):

* floats are read as YAML 1.2 does: ``1e5``, ``2.0e6``, ``-3E-2`` are numbers
  (YAML 1.1 wants a dot and a signed exponent, so PyYAML returns ``'1e5'`` as
  a string);
* a key given twice in one mapping is refused, naming the key and both lines
  (PyYAML silently keeps the last one);
* every failure (missing file, undecodable bytes, syntax) is raised as the
  caller's package error naming the file, never a bare ``OSError``,
  ``UnicodeDecodeError`` or ``yaml.YAMLError``.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Hashable, Iterable
from pathlib import Path

import yaml

#: YAML 1.2 core-schema float (plus the 1.1 forms PyYAML already knows).
_FLOAT_12 = re.compile(
    r"""^(?:[-+]?(?:\.[0-9]+|[0-9][0-9_]*(?:\.[0-9_]*)?)(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.X,
)


class DuplicateKeyError(yaml.constructor.ConstructorError):  # type: ignore[misc]
    """A mapping names one key twice.

    Raised inside the loader and re-raised as the caller's error.
    """


class StrictLoader(yaml.SafeLoader):  # type: ignore[misc]
    """SafeLoader with YAML 1.2 floats and duplicate keys refused."""

    def construct_mapping(
        self, node: yaml.MappingNode, deep: bool = False
    ) -> dict[Hashable, object]:
        """Build a mapping, refusing a key given twice (naming it and both lines).

        Raises
        ------
        DuplicateKeyError
            A key occurs twice in the mapping ``node``.
        """
        seen: dict[Hashable, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            try:
                first = seen.get(key)
            except TypeError:  # unhashable key: the base class reports it
                continue
            if first is not None:
                raise DuplicateKeyError(
                    None, None, f'duplicate key {key!r} on line {line} (first on line {first})'
                )
            seen[key] = line
        mapping: dict[Hashable, object] = super().construct_mapping(node, deep=deep)
        return mapping


def _float_resolver_first() -> None:
    resolvers = {k: list(v) for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    for ch in '-+0123456789.':
        lst = [r for r in resolvers.get(ch, []) if r[0] != 'tag:yaml.org,2002:float']
        # ints keep priority (their resolver matches first); floats per YAML 1.2 next
        lst.append(('tag:yaml.org,2002:float', _FLOAT_12))
        resolvers[ch] = lst
    StrictLoader.yaml_implicit_resolvers = resolvers


_float_resolver_first()


def parse_yaml(text: str, source: str, error: type[Exception]) -> object:
    """Parse ``text`` (from ``source``, for messages) with :class:`StrictLoader`.

    Returns
    -------
    object
        The document: mappings, lists, str, int, float, bool or None.

    Raises
    ------
    Exception
        ``error``, with one line naming ``source``, for any syntax problem.
    """
    try:
        return yaml.load(text, Loader=StrictLoader)
    except DuplicateKeyError as exc:
        raise error(f'{source}: {exc.problem}') from None
    except yaml.MarkedYAMLError as exc:
        where = f' (line {exc.problem_mark.line + 1})' if exc.problem_mark else ''
        raise error(f'{source}: invalid YAML{where}: {exc.problem or exc}') from None
    except yaml.YAMLError as exc:
        raise error(f'{source}: invalid YAML: {str(exc).splitlines()[0]}') from None
    except RecursionError:
        raise error(f'{source}: YAML nested too deeply') from None


def load_yaml(path: str | Path, error: type[Exception], what: str = 'config') -> object:
    """Read and parse the YAML file ``path`` (``what`` names it in messages).

    Raises
    ------
    Exception
        ``error``, naming the file, when it is missing, unreadable or not YAML.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding='utf-8')
    except UnicodeDecodeError as exc:
        raise error(f'{p}: {what} is not UTF-8 text (byte {exc.start})') from None
    except OSError as exc:
        raise error(f'{p}: cannot read {what} ({exc.strerror or exc})') from None
    return parse_yaml(text, str(p), error)


def check_keys(
    data: Iterable[object],
    known: Iterable[str],
    source: str,
    error: type[Exception],
    what: str = 'key',
) -> None:
    """Refuse keys not in ``known``, suggesting the closest known key (difflib)."""
    names = sorted(known)
    for key in data:
        if key in names:
            continue
        close = difflib.get_close_matches(str(key), names, n=1, cutoff=0.6)
        hint = f' (did you mean {close[0]!r}?)' if close else f' (known: {", ".join(names)})'
        raise error(f'{source}: unknown {what} {key!r}{hint}')


__all__ = ['StrictLoader', 'check_keys', 'load_yaml', 'parse_yaml']
