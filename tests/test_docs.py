"""The API reference: every parameter of the public API is described in its docstring."""
import enum
import inspect
import re

import fasttrack

#: numpydoc sections whose entries describe parameters.
_PARAMETER_SECTIONS = ("Parameters", "Other Parameters")


def _sections(doc):
    """``{title: [lines]}`` of the numpydoc sections of a cleaned docstring (a title line
    underlined by dashes)."""
    lines = doc.splitlines()
    sections, title = {}, None
    for i, line in enumerate(lines):
        if i + 1 < len(lines) and line.strip() and not line.startswith(" ") \
                and re.fullmatch(r"-{3,}", lines[i + 1].strip()) \
                and len(lines[i + 1].strip()) >= len(line.strip()):
            title = line.strip()
            sections.setdefault(title, [])
        elif title is not None and not re.fullmatch(r"-{3,}", line.strip()):
            sections[title].append(line)
    return sections


def documented_parameters(doc):
    """Names with an entry ``name : type`` (or ``a, b : type``) in a Parameters section."""
    names = set()
    for title, lines in _sections(inspect.cleandoc(doc or "")).items():
        if title not in _PARAMETER_SECTIONS:
            continue
        for line in lines:  # descriptions are indented, entries are not
            entry = re.match(r"(\*{0,2}\w+(?:\s*,\s*\*{0,2}\w+)*)\s+:(?:\s|$)", line)
            if entry:
                names.update(name.strip().lstrip("*") for name in entry[1].split(","))
    return names


def _parameters(function, skip_first=False):
    """Names in ``function``'s signature, without the first (``self`` or ``cls``) if
    ``skip_first``."""
    params = list(inspect.signature(function).parameters.values())
    if skip_first:
        params = params[1:]
    return [p.name for p in params]


def _public_methods(cls):
    """``{name: (function, bound)}`` of the public methods (plain, class and static) that
    ``cls`` has from classes defined in fasttrack, its own or inherited; ``bound`` says
    whether the function's first parameter is ``self`` or ``cls``."""
    methods = {}
    for klass in reversed(cls.__mro__):
        if not klass.__module__.startswith("fasttrack"):
            continue
        for name, attr in vars(klass).items():
            if name.startswith("_"):
                continue
            if isinstance(attr, (classmethod, staticmethod)):
                methods[name] = (attr.__func__, isinstance(attr, classmethod))
            elif inspect.isfunction(attr):
                methods[name] = (attr, True)
            else:
                methods.pop(name, None)  # overridden by a property or an attribute
    return methods


def undocumented(objects):
    """``{qualified name: [undocumented parameters]}`` over classes and functions, and the
    public methods of the classes."""
    missing = {}

    def check(name, params, *docs):
        documented = set().union(*(documented_parameters(d) for d in docs))
        gaps = [p for p in params if p not in documented]
        if gaps:
            missing[name] = gaps

    for name, obj in objects:
        if inspect.isclass(obj):
            if not issubclass(obj, enum.Enum):  # an enum's call is Enum's functional API
                check(name, _parameters(obj), inspect.getdoc(obj),
                      inspect.getdoc(obj.__init__))
            for method, (function, bound) in _public_methods(obj).items():
                check(f"{name}.{method}", _parameters(function, skip_first=bound),
                      inspect.getdoc(getattr(obj, method)))
        elif inspect.isfunction(obj):
            check(name, _parameters(obj), inspect.getdoc(obj))
    return missing


def _public_api():
    return [(name, getattr(fasttrack, name)) for name in fasttrack.__all__]


def test_every_public_parameter_is_documented():
    missing = undocumented(_public_api())
    assert not missing, "parameters without a numpydoc entry:\n" + "\n".join(
        f"  {name}: {', '.join(params)}" for name, params in sorted(missing.items()))


def test_the_parameter_check_reads_numpydoc_entries():
    def f(a, b, c, d, e):
        """Summary mentioning ``e``.

        Parameters
        ----------
        a : int
            Mentions d in passing.
        b, c : float

        Returns
        -------
        d : float
        """

    assert documented_parameters(f.__doc__) == {"a", "b", "c"}
    assert undocumented([("f", f)]) == {"f": ["d", "e"]}
