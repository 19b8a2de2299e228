"""Joint angles, RULA and REBA scoring, shift aggregation and CSV export."""
