"""A node's executable (a script without .py under nodes/) loaded as a module, for tests.

Unit tests drive a node's classes with fakes; its file has no .py suffix, so the import
system needs a SourceFileLoader. Loaded once per call, under the name given.
"""
import importlib.machinery
import importlib.util


def load_node_module(path, name):
    """The module at `path` (a node's executable), imported under `name`."""
    loader = importlib.machinery.SourceFileLoader(name, str(path))
    spec = importlib.util.spec_from_loader(loader.name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module
