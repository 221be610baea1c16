// Fresnel splitting along the refracted chain (FRESNEL_SPLITS = k, the parameter
// fresnel_splits): photon slot j = b·batch_slots + i is emission texel i's photon in batch
// b of k + 1. Batch b < k refracts at interactions 0..b−1 (0: the emission's), reflects at
// b; batch k refracts at 0..k−1; then each chooses by its Fresnel number. Twin of
// scenes/splitting.py (the specification lives there). Requires common/rng.glsl and the
// uniform `batch_slots`.
#ifndef VOLCAUSTICS_SPLIT_GLSL
#define VOLCAUSTICS_SPLIT_GLSL

#ifndef SPLIT_DIM
#define SPLIT_DIM 4u  // scenes.splitting.SPLIT_DIM
#endif

// xi, or the number of interaction `step`'s forced choice for slot `photon`: −1 reflects at
// R of the power, 2 refracts at 1 − R (common/interaction.glsl)
float split_number(float xi, uint photon, uint step) {
#ifdef FRESNEL_SPLITS
    uint batch = photon / batch_slots;
    if (step < min(batch, uint(FRESNEL_SPLITS))) return 2.0;
    if (step == batch && batch < uint(FRESNEL_SPLITS)) return -1.0;
#endif
    return xi;
}

// Whether slot `photon` is emitted under SPLIT_EVERY = m (split_every): a reflected batch
// keeps the slots whose stratified number is below 1/m (scenes.splitting.kept), at m times
// the power (`factor`); the last batch every slot, at 1
bool split_kept(uint seed, uint photon, out float factor) {
    factor = 1.0;
#if defined(FRESNEL_SPLITS) && defined(SPLIT_EVERY)
    uint batch = photon / batch_slots;
    if (batch < uint(FRESNEL_SPLITS)) {
        factor = float(SPLIT_EVERY);
        return stratified_uniform(seed, photon % batch_slots, batch, SPLIT_DIM) < 1.0 / float(SPLIT_EVERY);
    }
#endif
    return true;
}

// Whether the segment of step `step` (1-based) of slot `photon` is another batch's: not splatted
bool split_silent(uint photon, uint step) {
#ifdef FRESNEL_SPLITS
    uint batch = photon / batch_slots;
    return batch < uint(FRESNEL_SPLITS) && step <= batch;
#else
    return false;
#endif
}

#endif
