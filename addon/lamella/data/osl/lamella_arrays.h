// Lamella look-up tables for OSL, as constant arrays inside the shader: multilinear reads of the
// tables of lamella.core.luts with the same nodes and clamping as the EXR reads of lamella_luts.h.
// Inlined by the emitter (lamella/core/backends/osl/emit.py) into a shader whose tables travel in
// its source (Blender's Script node: a .blend renders without any file beside it). A table of shape
// (n0, n1) is stored row by row; one of shape (n0, n1, n2) as its n2 slices of n0 x n1, one after
// the other. A coordinate c in [0, 1] of an axis with n nodes sits at c * (n - 1).

float lamella_arr2(float T[], int base, float c0, float c1, int n0, int n1)
{
    float x = clamp(c0, 0.0, 1.0) * (n0 - 1);
    int i = min((int)floor(x), n0 - 2);
    float fx = x - i;
    float y = clamp(c1, 0.0, 1.0) * (n1 - 1);
    int j = min((int)floor(y), n1 - 2);
    float fy = y - j;
    int a = base + i * n1 + j;
    float lo = T[a] + (T[a + 1] - T[a]) * fy;
    float hi = T[a + n1] + (T[a + n1 + 1] - T[a + n1]) * fy;
    return lo + (hi - lo) * fx;
}

float lamella_arr3(float T[], float c0, float c1, float c2, int n0, int n1, int n2)
{
    float z = clamp(c2, 0.0, 1.0) * (n2 - 1);
    int k = min((int)floor(z), n2 - 2);
    float f = z - k;
    float a = lamella_arr2(T, k * n0 * n1, c0, c1, n0, n1);
    float b = lamella_arr2(T, (k + 1) * n0 * n1, c0, c1, n0, n1);
    return a + (b - a) * f;
}
