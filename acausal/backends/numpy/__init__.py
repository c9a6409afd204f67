"""The numpy backend: the program printed as Python functions over numpy arrays, the functions printed on demand,
and the numeric helpers the printed code calls."""
