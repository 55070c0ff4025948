"""Reports: self-contained HTML pages with figures and tables (``Report``, ``quicklook``) and 3D
animations (``animate``, ``animation_iframe``)."""

from .html import Report as Report
from .html import quicklook as quicklook
from .animate import animate as animate
from .animate import animation_iframe as animation_iframe
