"""Robustness campaigns: every registered estimator against many cars, parameter errors and noise."""

from vehicle_observers import estimation  # noqa: F401  (registers every estimator, the references too)
from vehicle_observers.campaign import truths  # noqa: F401  (registers the built-in plants)
from vehicle_observers.campaign.engine import CampaignSummary, run
from vehicle_observers.campaign.spec import Spec, SpecError, load_spec
from vehicle_observers.campaign.store import read_lmi, read_results

__all__ = ["CampaignSummary", "Spec", "SpecError", "load_spec", "read_lmi", "read_results", "run"]
