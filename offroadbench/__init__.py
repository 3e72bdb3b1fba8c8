"""offroadbench: benchmark off-road ground vehicles on synthetic terrain."""

from importlib.metadata import PackageNotFoundError, version as _version

from offroadbench.errors import InputError
from offroadbench.heightmap import Heightmap

try:
    __version__ = _version("offroadbench")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["Heightmap", "InputError", "__version__"]
