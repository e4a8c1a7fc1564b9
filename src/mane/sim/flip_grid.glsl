// Chen's FLIP volume grid: a staggered MAC grid of GRID_RES^3 cubic cells around the GridBounds box.
// Pressure at cell centres, u/v/w on the faces. The box spans cells 1..R-2; cells outside the
// domain count as air (p = 0), so the grid's edge is a free surface, not a wall.
#include "grid_bounds.glsl"

const uint AIR = 0u;
const uint FLUID = 1u;
const uint SOLID = 2u;

const int R = GRID_RES;
const uint NUM_CELLS = uint(R * R * R);
const uint FACES_PER_AXIS = uint((R + 1) * R * R);

struct Cell {
    float p;        // pressure (scaled: the rho/dt factor is dropped)
    float r;        // PCG residual
    float z;        // preconditioned residual
    float d;        // search direction
    float q;        // A d
    float density;  // trilinear particle mass at the cell centre (mass units)
    uint marker;    // AIR, FLUID, SOLID
    float diag;     // number of non-solid neighbours (the Jacobi preconditioner)
};

float grid_h() {
    vec3 e = bounds_hi.xyz - bounds_lo.xyz;
    return max(max(e.x, max(e.y, e.z)), 1e-30) / float(R - 2);
}
vec3 grid_origin(float h) {
    return 0.5 * (bounds_lo.xyz + bounds_hi.xyz) - vec3(0.5 * float(R) * h);
}

uint cell_index(ivec3 c) { return uint(c.x + R * (c.y + R * c.z)); }
ivec3 cell_coord(uint n) { return ivec3(int(n) % R, (int(n) / R) % R, int(n) / (R * R)); }
bool in_domain(ivec3 c) { return all(greaterThanEqual(c, ivec3(0))) && all(lessThan(c, ivec3(R))); }

ivec3 face_dims(int a) { ivec3 d = ivec3(R); d[a] += 1; return d; }
uint face_index(int a, ivec3 f) {
    ivec3 d = face_dims(a);
    return uint(a) * FACES_PER_AXIS + uint(f.x + d.x * (f.y + d.y * f.z));
}
ivec3 face_coord(int a, uint local) {
    ivec3 d = face_dims(a);
    int n = int(local);
    return ivec3(n % d.x, (n / d.x) % d.y, n / (d.x * d.y));
}

// trilinear stencil of component a's faces around point g_cells = (x - origin) / h
struct FaceStencil { ivec3 base; vec3 frac; };
FaceStencil face_stencil(int a, vec3 g_cells) {
    vec3 shift = vec3(0.5);
    shift[a] = 0.0;
    ivec3 d = face_dims(a);
    vec3 g = clamp(g_cells - shift, vec3(0.0), vec3(d - 1));
    FaceStencil s;
    s.base = min(ivec3(floor(g)), d - 2);
    s.frac = g - vec3(s.base);
    return s;
}
float corner_weight(vec3 f, ivec3 c) {
    vec3 w = mix(vec3(1.0) - f, f, vec3(c));
    return w.x * w.y * w.z;
}
ivec3 corner_offset(int c) { return ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

float particle_mass(float inverse_mass, float pinned_mass, float inv_mass_unit) {
    return (inverse_mass > 0.0 ? 1.0 / inverse_mass : pinned_mass) * inv_mass_unit;
}
