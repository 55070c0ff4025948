"""Design studies: DOE, optimisation and sensitivity on vmap batches, local processes and a
Dask cluster, with a resumable Parquet store (``proleg.study.Study``)."""

from .space import Choice as Choice
from .space import Fixed as Fixed
from .space import LogRange as LogRange
from .space import Range as Range
from .space import Space as Space
from .design import make_design as make_design
from .store import Store as Store
from .study import Study as Study
