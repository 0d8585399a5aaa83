// Lamella look-up tables for OSL: multilinear reads of the tables of lamella.core.luts.
// Inlined by the emitter (lamella/core/backends/osl/emit.py) into every generated shader, so a
// shader only needs the EXR files in `lut_dir`. Tables are node-centred: a coordinate c in [0, 1]
// of an axis with n nodes sits at c * (n - 1). 3D tables are atlases of their last axis's slices
// stacked vertically (rows = first axis, columns = second axis), as lamella.core.luts writes them;
// lamella_tex4 reads four slices at once from a table's RGBA-packed atlas (luts.PACKED).
// lamella LUT layout 2: every file holds its atlas above its mirror image, and an atlas row is read
// at half its t, which is the same texel whether a renderer counts t from the file's first row
// (OpenImageIO, Blender up to 5.0) or from its last (Cycles from Blender 5.1).

float lamella_tex(string file, float c0, float c1, int n0, int n1, float row0, int rows)
{
    float s = (clamp(c1, 0.0, 1.0) * (n1 - 1) + 0.5) / n1;
    float t = (row0 + clamp(c0, 0.0, 1.0) * (n0 - 1) + 0.5) / (2 * rows);
    return texture(file, s, t, "wrap", "clamp", "interp", "linear", "width", 0.0);
}

color lamella_tex4(string file, float c0, float c1, int n0, int n1, float row0, int rows, output float a)
{
    float s = (clamp(c1, 0.0, 1.0) * (n1 - 1) + 0.5) / n1;
    float t = (row0 + clamp(c0, 0.0, 1.0) * (n0 - 1) + 0.5) / (2 * rows);
    return texture(file, s, t, "wrap", "clamp", "interp", "linear", "width", 0.0, "alpha", a);
}

float lamella_lut2(string file, float c0, float c1, int n0, int n1)
{
    return lamella_tex(file, c0, c1, n0, n1, 0.0, n0);
}

float lamella_lut3(string file, float c0, float c1, float c2, int n0, int n1, int n2)
{
    float x = clamp(c2, 0.0, 1.0) * (n2 - 1);
    float k = min(floor(x), n2 - 2);
    float f = x - k;
    float a = lamella_tex(file, c0, c1, n0, n1, k * n0, n0 * n2);
    float b = lamella_tex(file, c0, c1, n0, n1, (k + 1) * n0, n0 * n2);
    return a + (b - a) * f;
}
