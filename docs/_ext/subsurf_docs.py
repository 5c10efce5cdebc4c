"""Sphinx glue for subsurf's site: the API pages, a docstring normaliser and a coverage check.

- :func:`write_api_pages` writes ``docs/api/*.rst`` from the package itself (``subsurf._EXPORTS``,
  ``subsurf._SUBMODULES`` and each submodule's ``__all__``), so a new public name is documented
  without anyone editing a page. The names of the package root (``subsurf.Layer``) are documented
  there; a submodule's page leaves out what the root re-exports and links to it instead.
- :func:`normalise_docstring` turns the project's compact sections (``name : description`` under
  ``Parameters``/``Attributes``, free text under ``Returns``, other titled sections) into what
  napoleon and docutils read, so docstrings stay short in the source and render as field lists.
- :func:`check_coverage` fails the build (a warning, an error under ``-W``) when a public name has
  no entry in the built API reference.
"""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

#: Modules with a page besides those the package root exposes as attributes.
EXTRA_MODULES = ("render.export",)

_FIELD_SECTIONS = ("Parameters", "Other Parameters", "Keyword Arguments", "Attributes")
_NAPOLEON_SECTIONS = (*_FIELD_SECTIONS, "Returns", "Yields", "Raises", "Warns", "See Also", "Notes", "References")
_FIELD = re.compile(r"^(\s*)([\w*]+(?:\s*,\s*[\w*]+)*)\s+:\s+(.*)$")


def _modules():
    import subsurf

    return [f"subsurf.{m}" for m in (*subsurf._SUBMODULES, *EXTRA_MODULES)]


def _root_names() -> dict:
    """Root name → defining submodule, in the order of ``subsurf._EXPORTS``."""
    import subsurf

    return dict(subsurf._EXPORTS)


def _public(modname: str) -> list:
    mod = importlib.import_module(modname)
    names = getattr(mod, "__all__", None)
    if names is None:
        names = [
            n
            for n, v in vars(mod).items()
            if not n.startswith("_") and getattr(v, "__module__", None) == modname and callable(v)
        ]
    return list(names)


def _directive(obj) -> str:
    if inspect.isclass(obj):
        return "autoexception" if issubclass(obj, BaseException) else "autoclass"
    if callable(obj):
        return "autofunction"
    return "autodata"


def _root_page() -> str:
    import subsurf

    out = ["Package ``subsurf``", "===================", "", ".. automodule:: subsurf", "   :no-members:", ""]
    by_module: dict = {}
    for name, mod in _root_names().items():
        by_module.setdefault(mod, []).append(name)
    for mod, names in by_module.items():
        title = f"From ``subsurf.{mod}``" if mod != "_core" else "From the compiled core"
        out += [title, "-" * len(title), ""]
        for name in names:
            d = _directive(getattr(subsurf, name))
            out += [f".. {d}:: subsurf.{name}", *(["   :no-value:"] if d == "autodata" else []), ""]
    return "\n".join(out)


def _is_data(obj) -> bool:
    return not (inspect.isclass(obj) or callable(obj) or inspect.ismodule(obj))


def _module_page(modname: str) -> str:
    """automodule for the functions and classes; autodata for each constant of ``__all__``
    (autodoc documents module data only when it has a ``#:`` comment)."""
    import subsurf

    mod = importlib.import_module(modname)
    root = _root_names()
    reexported = [n for n in root if hasattr(mod, n) and getattr(mod, n) is getattr(subsurf, n)]
    data = [n for n in _public(modname) if n not in reexported and _is_data(getattr(mod, n))]
    title = f"``{modname}``"
    out = [title, "=" * len(title), "", f".. automodule:: {modname}"]
    if reexported or data:
        out.append(f"   :exclude-members: {', '.join(reexported + data)}")
    out.append("")
    if reexported:
        refs = ", ".join(
            f":{'class' if inspect.isclass(getattr(subsurf, n)) else 'obj'}:`subsurf.{n}`" for n in reexported
        )
        out += [f"Also defined here and documented at the package root: {refs}.", ""]
    for n in data:
        out += [f".. autodata:: {modname}.{n}", *(["   :no-value:"] if len(repr(getattr(mod, n))) > 100 else []), ""]
    return "\n".join(out)


def write_api_pages(srcdir: str | Path) -> None:
    """Write ``api/index.rst`` and one page per module, touching only files whose text changed."""
    api = Path(srcdir) / "api"
    api.mkdir(exist_ok=True)
    mods = _modules()
    pages = {"subsurf": _root_page(), **{m: _module_page(m) for m in mods}}
    index = [
        "API reference",
        "=============",
        "",
        "Generated from the docstrings of every public object. Units are mm and mm⁻¹ throughout.",
        "",
        ".. toctree::",
        "   :maxdepth: 1",
        "",
        *(f"   {name}" for name in pages),
        "",
    ]
    pages["index"] = "\n".join(index)
    for name, text in pages.items():
        path = api / f"{name}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
    for stale in api.glob("*.rst"):
        if stale.stem not in pages:
            stale.unlink()


def _is_rule(line: str) -> bool:
    s = line.strip()
    return len(s) >= 3 and set(s) == {"-"}


def _is_header(lines: list, i: int) -> bool:
    return i + 1 < len(lines) and bool(lines[i].strip()) and _is_rule(lines[i + 1])


def _indent(line: str) -> str:
    return line[: len(line) - len(line.lstrip())]


def _field_section_end(lines: list, start: int, indent: str) -> int:
    """Index after the fields starting at ``start``: ``name : text`` lines at ``indent``, their
    deeper-indented continuations, and blank lines between them."""
    i = end = start
    while i < len(lines) and not _is_header(lines, i):
        line = lines[i]
        if line.strip():
            if _indent(line) == indent and not _FIELD.match(line):
                break
            end = i + 1
        i += 1
    return end


def _section_end(lines: list, start: int) -> int:
    i = start
    while i < len(lines) and not _is_header(lines, i):
        i += 1
    return i


def normalise_docstring(lines: list) -> list:
    """The project's compact numpydoc dialect as napoleon's numpydoc (see the module docstring)."""
    out: list = []
    i = 0
    while i < len(lines):
        if not _is_header(lines, i):
            out.append(lines[i])
            i += 1
            continue
        header, rule = lines[i], lines[i + 1]
        title, indent = header.strip(), _indent(header)
        if title in _FIELD_SECTIONS:
            end = _field_section_end(lines, i + 2, indent)
            out += [header, rule]
            for line in lines[i + 2 : end]:
                m = _FIELD.match(line)
                if m and m.group(1) == indent:
                    out += [f"{indent}{m.group(2)}", f"{indent}    {m.group(3)}"]
                else:
                    out.append(line)
            if end < len(lines) and not _is_header(lines, end):
                out += ["", ""]  # napoleon ends a section at two blank lines; the text after is prose
            i = end
            continue
        end = _section_end(lines, i + 2)
        body = lines[i + 2 : end]
        if title == "Returns" and body and not _FIELD.match(body[0]):
            text = [t.strip() for t in body]
            while text and not text[-1]:
                text.pop()
            out += [f"{indent}:returns: {text[0]}", *(f"{indent}    {t}" for t in text[1:]), ""]
        elif title in _NAPOLEON_SECTIONS:
            out += [header, rule, *body]
        else:
            out += [f"{indent}.. rubric:: {title}", "", *body]
        i = end
    return out


_LITERAL = re.compile(r"(``.*?``)")


def escape_bars(line: str) -> str:
    """``|g|`` means an absolute value in these docstrings, never a substitution: escape the bars
    outside inline literals."""
    parts = _LITERAL.split(line)
    return "".join(p if i % 2 else p.replace("|", "\\|") for i, p in enumerate(parts))


def _process_docstring(app, what, name, obj, options, lines) -> None:
    lines[:] = [escape_bars(line) for line in normalise_docstring(lines)]


def public_names() -> set:
    """Every name the API reference must have: root names, modules, and each module's ``__all__``
    (less what the root re-exports, documented there)."""
    import subsurf

    root = _root_names()
    wanted = {f"subsurf.{n}" for n in root} | set(_modules())
    for modname in _modules():
        mod = importlib.import_module(modname)
        wanted |= {
            f"{modname}.{n}" for n in _public(modname) if not (n in root and getattr(mod, n) is getattr(subsurf, n))
        }
    return wanted


def check_coverage(app, exception) -> None:
    """Warn (an error under ``-W``) about public names without an entry in the API reference."""
    if exception is not None or app.builder.name != "html":
        return
    from sphinx.util import logging

    missing = sorted(public_names() - set(app.env.domains["py"].objects))
    if missing:
        logging.getLogger(__name__).warning("public names without an API entry: %s", ", ".join(missing))


def setup(app):
    app.connect("builder-inited", lambda app: write_api_pages(app.srcdir))
    # Before napoleon (priority 500) so that it sees the normalised sections.
    app.connect("autodoc-process-docstring", _process_docstring, priority=400)
    app.connect("build-finished", check_coverage)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
