//! Reading and writing image files (EXR, PNG, Radiance HDR, PFM).
