"""The parameter reference ``docs/parameters.md``, rendered from the specs (no rclpy).

``python -m tribo_bringup.paramdocs > docs/parameters.md`` writes it; a test
keeps the file equal to :func:`render`. ``python -m tribo_bringup.paramdocs
--physics docs/physics.md`` regenerates the candidate table of ``docs/physics.md``
(section 8) from the candidate registry (:func:`render_physics`). The tables are those the nodes
declare from and the RIG.yaml loader validates with: the rig's
(:data:`tribo_estimation.core.rigspec.RIG_SPEC`) and one per node of the node
table (:data:`NODE_PARAMS`, from :data:`tribo_common.nodes.NODES`).
"""

from __future__ import annotations

from tribo_common.nodes import NODES
from tribo_common.paramspec import ParamSpec, markdown_table
from tribo_estimation.core.rigspec import RIG_OPTIONAL, RIG_REQUIRED, RIG_SPEC

#: Node name -> the parameters it declares from a spec (the node table's spec sources).
NODE_PARAMS: dict[str, tuple[ParamSpec, ...]] = {n.name: n.param_specs() for n in NODES}


def render() -> str:
    """Return the Markdown text of ``docs/parameters.md``."""
    parts = [
        '# Parameters\n',
        'Generated from the parameter specs by `python -m tribo_bringup.paramdocs > '
        'docs/parameters.md` (a test keeps this file current). SI units; ranges are '
        "inclusive; defaults of the rig are the paper's Tab. 1 (`config/rig.yaml`).\n",
        '## Rig (RIG.yaml, `tribo_estimation.core.rigspec`)\n',
        f'Required: {", ".join(f"`{k}`" for k in RIG_REQUIRED)}; optional (absent: 0): '
        f'{", ".join(f"`{k}`" for k in RIG_OPTIONAL)} and `effects` (hidden model '
        'extensions, fields of `tribo_estimation.core.model.Extensions`).\n',
        markdown_table(RIG_SPEC),
        '## Nodes (`tribo_common.nodes`)\n',
        node_table(),
    ]
    for info in NODES:
        node, specs = info.name, NODE_PARAMS[info.name]
        rig = [s.name for s in specs if s.name in RIG_SPEC]
        own = [s for s in specs if s.name not in RIG_SPEC]
        parts.append(f'## Node `{node}`\n')
        parts.append(f'{info.description[:1].upper()}{info.description[1:]}.\n')
        if rig:
            parts.append(f'Rig parameters (as above): {", ".join(f"`{n}`" for n in rig)}.\n')
        if node == 'sim_rig':
            parts.append('Also `effects.<name>` for every hidden extension (default 0).\n')
        parts.append(markdown_table(own))
    return '\n'.join(parts)


def node_table() -> str:
    """Return the Markdown table of the graph's nodes (:data:`tribo_common.nodes.NODES`).

    Returns
    -------
    str
        One row per node: executable, package, kind, lifecycle, parameter file and
        the ``tribo run`` option that starts it.
    """
    rows = [
        '| executable | package | kind | lifecycle | parameter file | `tribo run` |',
        '|---|---|---|---|---|---|',
    ]
    for n in NODES:
        start = next((f'`{o.flag} {o.metavar}`' for o in n.run_options if o.starts), '')
        config = f'`config/{n.config}`' if n.config else ''
        lifecycle = 'yes' if n.lifecycle else 'no'
        rows.append(
            f'| `{n.name}` | {n.package} | {n.kind.value} | {lifecycle} | {config} | {start} |'
        )
    return '\n'.join(rows) + '\n'


#: Markers around the generated candidate table in ``docs/physics.md``.
CANDIDATES_BEGIN = (
    '<!-- candidate table: python -m tribo_bringup.paramdocs --physics docs/physics.md -->'
)
CANDIDATES_END = '<!-- end of candidate table -->'


def render_physics(text: str) -> str:
    """Return ``docs/physics.md`` with its candidate table regenerated from the registry.

    Parameters
    ----------
    text : str
        The current text; the table sits between :data:`CANDIDATES_BEGIN` and
        :data:`CANDIDATES_END`.

    Returns
    -------
    str
        The text with the table of
        :func:`tribo_estimation.core.discrepancy.candidates.candidate_table`.
    """
    from tribo_estimation.core.discrepancy.candidates import candidate_table

    head, sep, rest = text.partition(CANDIDATES_BEGIN + '\n')
    _, sep2, tail = rest.partition(CANDIDATES_END)
    if not (sep and sep2):
        raise SystemExit(f'docs/physics.md: markers {CANDIDATES_BEGIN!r} ... missing')
    return head + sep + candidate_table() + sep2 + tail


if __name__ == '__main__':
    import sys
    from pathlib import Path

    if sys.argv[1:2] == ['--physics'] and len(sys.argv) == 3:
        doc = Path(sys.argv[2])
        doc.write_text(render_physics(doc.read_text(encoding='utf-8')), encoding='utf-8')
    else:
        print(render(), end='')
