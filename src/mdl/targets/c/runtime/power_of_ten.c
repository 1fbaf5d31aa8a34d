/* Scale factors of a generated C driver (copied when a value is scaled by scale_exponent). */

/* 10^|e| as every target computes it (docs/bits-and-scale.md): 1.0 multiplied by 10.0 |e| times,
 * exact up to 10^22. */
static double mdl_power_of_ten(double e) {
    const int n = (int)(e < 0.0 ? -e : e);
    double p = 1.0;
    int i;
    for (i = 0; i < n; ++i) {
        p *= 10.0;
    }
    return p;
}
