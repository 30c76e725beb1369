//! BSDF validation: sampling densities, energy, reciprocity, Fresnel.
