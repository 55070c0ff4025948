"""Classical identification from measurements (seed 000 Eqs. 4–7, seed 003 Eq. 9).

Stiffness from the RMS line of force–stroke data, damping and Coulomb friction from hysteresis
loops, damping from a drop test, the battery model, and statistics over repetitions with
Student-t intervals. Files are read and checked by :mod:`proleg.identify.data`.
Experimental modal analysis (:func:`modal`: pyFRF FRFs, pyEMA LSCF + LSFD, a stabilisation
diagram picked automatically), UFF files (:func:`read_uff`), MAC, and calibration records that
keep fitted-on data apart from validation (:class:`Calibrated`).
"""

from .classical import Cycle as Cycle
from .classical import HysteresisResult as HysteresisResult
from .classical import LineFit as LineFit
from .classical import coulomb_fit as coulomb_fit
from .classical import detect_cycles as detect_cycles
from .classical import identify_hysteresis as identify_hysteresis
from .classical import loop_energy as loop_energy
from .classical import loops_table as loops_table
from .classical import plot_hysteresis as plot_hysteresis
from .classical import stiffness_rms as stiffness_rms
from .battery import BatteryFit as BatteryFit
from .battery import fit_battery as fit_battery
from .battery import plot_battery as plot_battery
from .drop import DropResult as DropResult
from .drop import drop_damping as drop_damping
from .data import Record as Record
from .data import load_record as load_record
from .data import parse_units as parse_units
from .data import read_table as read_table
from .data import split_runs as split_runs
from .stats import Interval as Interval
from .stats import mean_interval as mean_interval
from .stats import repetition_check as repetition_check
from .stats import repetitions_table as repetitions_table
from .fit import FitResult as FitResult
from .fit import fit as fit
from .fit import plot_fit as plot_fit
from .fit import signal as signal
from .hammer import ModalIdentification as ModalIdentification
from .hammer import StabilisationDiagram as StabilisationDiagram
from .hammer import frf_estimate as frf_estimate
from .hammer import modal_from_frf as modal_from_frf
from .correlation import auto_mac as auto_mac
from .calibration import Calibrated as Calibrated
from .calibration import calibrate as calibrate
from .calibration import check_held_out as check_held_out
from .calibration import split_scores as split_scores
from .uff import read_uff as read_uff
from .uff import read_modes_uff as read_modes_uff
from .uff import write_frf_uff as write_frf_uff
from .uff import write_modes_uff as write_modes_uff
from .hammer import comparison_table as modal_comparison_table
from .hammer import mac as mac
from .hammer import modal as modal
from .hammer import synthetic_hammer_test as synthetic_hammer_test
