// Sorted blending (OIT_METHOD 1): the patches arrive back to front (a compute sort of the
// guide segments by view depth); premultiplied "over" blending, depth test on, no depth writes.
#if OIT_METHOD == 1
layout(early_fragment_tests) in;
void oit_main() {
    frag = oit_color();
}
#endif
