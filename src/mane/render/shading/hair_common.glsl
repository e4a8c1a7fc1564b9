// Angles of the hair frame shared by the fibre models (Marschner 2003 / Hunz 2016 sec. 3.1).
#ifndef MANE_HAIR_COMMON_GLSL
#define MANE_HAIR_COMMON_GLSL

struct HairAngles {
    float sin_i, cos_i;   // theta_i: light inclination from the normal plane
    float sin_o, cos_o;   // theta_o: view inclination
    float theta_i, theta_o;
    float cos_phi, phi;   // relative azimuth in [0, pi]
};

// ALU: 2 dot, 2 length, 1 cross, 3 atan (~40).
HairAngles hair_angles(vec3 T, vec3 V, vec3 L) {
    HairAngles a;
    a.sin_i = clamp(dot(T, L), -1.0, 1.0);
    a.sin_o = clamp(dot(T, V), -1.0, 1.0);
    vec3 lp = L - a.sin_i * T;
    vec3 vp = V - a.sin_o * T;
    a.cos_i = min(length(lp), 1.0);
    a.cos_o = min(length(vp), 1.0);
    a.theta_i = atan(a.sin_i, max(a.cos_i, 1e-30));
    a.theta_o = atan(a.sin_o, max(a.cos_o, 1e-30));
    float x = dot(vp, lp);
    float y = length(cross(vp, lp));
    // Either direction along T: the azimuth is undefined; pi/2 (any value is finite).
    a.phi = (abs(x) + y > 1e-12) ? atan(y, x) : HALF_PI;
    a.cos_phi = cos(a.phi);
    return a;
}

// asin / acos through atan: Mesa lowers asin/acos to polynomials with ~4e-4 absolute error,
// its atan is good to ~3e-6.
float hair_asin(float x) { x = clamp(x, -1.0, 1.0); return atan(x, sqrt(max(0.0, 1.0 - x * x))); }
float hair_acos(float x) { x = clamp(x, -1.0, 1.0); return atan(sqrt(max(0.0, 1.0 - x * x)), x); }

// Unit-integral Gaussian g(beta, x) = exp(-x^2 / (2 beta^2)) / (beta sqrt(2 pi)).
float hair_gaussian(float beta, float x) {
    return exp(-0.5 * x * x / (beta * beta)) * (0.39894228040143267794 / beta);
}

#endif
