"""Networks: the Illumination Estimation Network (IEN) and the NLOS network."""
