"""Griffe extension used by the API pages (``mkdocs.yml``): adapt the source's docstrings.

The docstrings of flagellum are numpydoc-like with reStructuredText inline markup, written
for readers of the source, and they keep types in the annotations. Rendered as Markdown by
mkdocstrings they would show raw reST and mis-parse the parameter lists, so before parsing
this extension rewrites (text only, in memory; the source is not touched):

* ``name : description`` items of ``Parameters``/``Attributes`` sections into
  ``name`` + indented description (numpydoc reads the text after `` : `` as a *type*),
  and ``a, b : text`` into one item per name;
* a free-text ``Returns`` section (``dict with …``) into an item typed by the annotation;
* reST roles ``:func:`x``` / ``:class:`~a.b.C``` into code spans;
* reST literal-block markers (``text ::``) into a plain colon (the indented block after a
  blank line is a code block in Markdown as well);
* reST simple tables (``=====  =====`` borders) into fenced text blocks.
"""

from __future__ import annotations

import re

import griffe

_ITEM_SECTIONS = {"parameters", "other parameters", "attributes", "keyword arguments"}
_ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|data|attr|exc|obj|const|term):`(~?)([^`]+)`")
_ITEM = re.compile(r"^(\*{0,2}[A-Za-z_][\w]*(?:\s*,\s*\*{0,2}[A-Za-z_][\w]*)*)\s+:\s+(\S.*)$")
_BORDER = re.compile(r"^\s*=+(?: +=+)+\s*$")
_UNDERLINE = re.compile(r"^\s*-{3,}\s*$")


def _sections(lines: list[str]):
    """Yield (title, start, end) of numpydoc sections: title line, underline, body lines."""
    heads = [i for i in range(len(lines) - 1)
             if lines[i].strip() and _UNDERLINE.match(lines[i + 1])
             and len(lines[i + 1].strip()) >= len(lines[i].strip()) - 1]
    for k, i in enumerate(heads):
        end = heads[k + 1] if k + 1 < len(heads) else len(lines)
        yield lines[i].strip().lower(), i, end


def rewrite(text: str) -> str:
    """The docstring ``text`` with the rewrites listed in the module docstring."""
    # :func:`a.b` → `a.b`;  :class:`~a.b.C` → `C` (reST's "~": last component only)
    text = _ROLE.sub(lambda m: "`" + (m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2)) + "`",
                     text)
    lines = text.split("\n")
    for title, head, end in reversed(list(_sections(lines))):
        body = list(range(head + 2, end))
        if title in _ITEM_SECTIONS:
            for i in reversed(body):
                m = _ITEM.match(lines[i])
                if not m:
                    continue
                j = i + 1  # continuation lines of the item's description
                while j < end and lines[j][:1].isspace() and lines[j].strip():
                    j += 1
                text = ["    " + m.group(2)] + lines[i + 1:j]
                names = [n.strip() for n in m.group(1).split(",")]
                # "a, b : text" → one item per name (griffe would give all of them a's type)
                lines[i:j] = [x for n in names for x in [n] + text]
        elif title == "returns":
            first = next((i for i in body if lines[i].strip()), None)
            free = first is not None and " " in lines[first].strip() and " : " not in lines[first] \
                and not any(lines[i][:1].isspace() for i in body if lines[i].strip())
            if free:  # numpydoc's "no name, no type" item: the annotation gives the type
                lines[head + 2:end] = [":"] + ["    " + lines[i] if lines[i].strip() else ""
                                               for i in body]
    out, in_table, borders = [], False, 0
    for line in lines:
        if _BORDER.match(line):
            if not in_table:
                out.append("```text")
                in_table, borders = True, 0
            borders += 1
            out.append(line)
            if borders == 3:
                out.append("```")
                in_table = False
            continue
        if not in_table:
            if line.strip() == "::":
                line = ""
            elif line.rstrip().endswith("::"):
                line = line.rstrip()[:-2].rstrip()
                line += "" if line[-1:] in ",.;:" else ":"
        out.append(line)
    if in_table:
        out.append("```")
    return "\n".join(out)


class ReSTDocstrings(griffe.Extension):
    """Rewrite every docstring with :func:`rewrite` before it is parsed."""

    def _fix(self, obj) -> None:
        if obj.docstring is not None:
            obj.docstring.value = rewrite(obj.docstring.value)

    def on_module_instance(self, *, mod, **kwargs) -> None:
        self._fix(mod)

    def on_class_instance(self, *, cls, **kwargs) -> None:
        self._fix(cls)

    def on_function_instance(self, *, func, **kwargs) -> None:
        self._fix(func)

    def on_attribute_instance(self, *, attr, **kwargs) -> None:
        self._fix(attr)
