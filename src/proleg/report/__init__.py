"""Reports: self-contained HTML pages with figures and tables (``Report``, ``quicklook``)."""

from .html import Report as Report
from .html import quicklook as quicklook
