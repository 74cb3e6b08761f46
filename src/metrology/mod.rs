//! Metrology: samples → SSM position errors, running circle fits, ISO 230-4 figures, point fits.
