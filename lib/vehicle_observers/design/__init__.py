"""LMI synthesis of observers on polytopic / TS systems, certified from the data."""
