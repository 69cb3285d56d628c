"""Names shared by the fleet summary's writer and its readers (kept light: no heavy imports)."""

__all__ = ["SUMMARY_FILE", "SUMMARY_SCHEMA"]

SUMMARY_SCHEMA = "escfit-fleet-summary/1"
SUMMARY_FILE = "summary.nc"
