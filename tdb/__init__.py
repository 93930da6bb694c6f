"""tdb: a terrain database and query engine for airborne LiDAR."""

from tdb.errors import TdbError

__version__ = "0.1.0"

__all__ = ["TdbError", "__version__"]

from tdb.database import Database, open

__all__ += ["Database", "open"]
