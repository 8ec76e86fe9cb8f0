"""Height fields by interval mapping (Shah 2007, ch. 3; Policarpo et al. 2005)."""
