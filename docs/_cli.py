"""vrelab's argument parser as the CLI reference reads it (docs/cli.rst, sphinx-argparse).

sphinx-argparse parses every help, description and epilog as reST, but they are written for a
terminal: ``|VRE|`` would be a substitution, ``*`` emphasis, an indented example manifest an
error. This copy of the parser escapes reST's inline markup in help texts and shows the texts a
formatter keeps as written (``RawDescriptionHelpFormatter``) as literal blocks, so any command
or option added to vrelab.cli appears here without a docs edit.
"""

from __future__ import annotations

import argparse
import re
import textwrap

from vrelab.cli import build_parser
from vrelab.cli._common import FORMATS_TOKEN, expand_formats

_INLINE = re.compile(r"([\\*`|_])")


def _escape(text: str | None) -> str | None:
    return None if text is None else _INLINE.sub(r"\\\1", text)


def _literal(text: str | None) -> str | None:
    if text is None or not text.strip():
        return text
    return ".. code-block:: text\n\n" + textwrap.indent(textwrap.dedent(text).strip("\n"), "    ")


def _prepare(parser: argparse.ArgumentParser) -> None:
    raw = issubclass(parser.formatter_class, argparse.RawDescriptionHelpFormatter)
    # the formats list is made from the reader registry when a help is printed: here, too
    description, epilog = expand_formats(parser.description), expand_formats(parser.epilog)
    parser.description = _literal(description) if raw else _escape(description)
    parser.epilog = _literal(epilog) if raw else _escape(epilog)
    for action in parser._actions:
        if action.help not in (None, argparse.SUPPRESS):
            if hasattr(action, "formats"):
                action.help = action.help.replace(FORMATS_TOKEN, str(action.formats))
            action.help = _escape(action.help)
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:
                choice.help = _escape(choice.help)
            for sub in dict.fromkeys(action.choices.values()):
                _prepare(sub)


def parser() -> argparse.ArgumentParser:
    p = build_parser()
    _prepare(p)
    return p
