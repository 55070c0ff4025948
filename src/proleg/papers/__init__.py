"""proleg.papers: the source papers' reproductions, apart from the library.

The robot builders and their data are :mod:`proleg.robots`; this package holds what reproduces
the papers with them: the HyQ leg's virtual bench tests (:mod:`~proleg.papers.hyq_tests`), the
scenario runners and their HTML reports (``*_report``), the design studies (``*_study``), the
FLEGX countermovement jump (:func:`flegx_jump`) and the Scout II bounding runs
(:func:`scout2_bound`). It ships inside the installed package so that ``proleg run NAME``
works after ``pip install proleg``; the CLI's scenario table (``proleg.cli.main.SCENARIOS``)
is the only place the library refers to it. It imports downward (robots, analyses, study,
report); no library module imports it.
"""

from .flegx_jump import flegx_jump as flegx_jump
from .scout2_bound import scout2_bound as scout2_bound
