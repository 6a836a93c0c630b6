"""Package attributes imported on first read (PEP 562), so that importing a package costs
only what a program uses."""
import importlib


def exports(package, modules):
    """``(__getattr__, __dir__)`` for ``package`` (its ``__name__``) whose public names live
    in its submodules: ``modules`` maps each submodule to the names it defines. A name is
    imported when first read, then kept; any submodule is an attribute too."""
    where = {name: module for module, names in modules.items() for name in names}

    def __getattr__(name):
        namespace = importlib.import_module(package).__dict__
        if name in where:
            value = getattr(importlib.import_module(f"{package}.{where[name]}"), name)
        else:
            try:
                value = importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as error:
                if error.name != f"{package}.{name}":
                    raise
                raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(importlib.import_module(package).__dict__) | set(where))

    return __getattr__, __dir__
