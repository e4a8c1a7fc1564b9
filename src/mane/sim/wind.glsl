// Wind velocity per strand and time (the formula is in mane/sim/wind.py).
uniform vec3 wind_velocity;     // m/s
uniform float wind_gust;        // fraction of |U|
uniform float wind_turbulence;  // m/s
uniform float wind_frequency;   // Hz
uniform float wind_jitter;      // noise periods
uniform int wind_octaves;
uniform uint wind_seed;

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

float hash_signed(uint i, uint seed) {
    uint h = pcg_hash(i ^ pcg_hash(seed));
    return float(h >> 8u) * (2.0 / 16777215.0) - 1.0;
}

float value_noise(float tau, uint seed) {
    float f = floor(tau);
    uint i = uint(int(f));
    float t = tau - f;
    float s = t * t * (3.0 - 2.0 * t);
    float a = hash_signed(i, seed);
    float b = hash_signed(i + 1u, seed);
    return a + (b - a) * s;
}

float fbm(float tau, uint seed) {
    float total = 0.0, amp = 1.0, norm = 0.0;
    for (int o = 0; o < wind_octaves; ++o) {
        total += amp * value_noise(tau * exp2(float(o)), seed + uint(o) * 1013u);
        norm += amp;
        amp *= 0.5;
    }
    return total / norm;
}

float strand_hash01(uint s) { return float(pcg_hash(s + 0x9E3779B9u) >> 8u) * (1.0 / 16777216.0); }

vec3 wind_at(uint strand, vec3 root, float t) {
    float speed = length(wind_velocity);
    vec3 dir = speed > 0.0 ? wind_velocity / speed : vec3(0.0);
    float tau = wind_frequency * (t - dot(root, dir) / max(speed, 0.5));
    tau += wind_jitter * strand_hash01(strand);
    float n0 = fbm(tau, wind_seed);
    float n1 = fbm(tau, wind_seed + 7919u);
    float n2 = fbm(tau, wind_seed + 2u * 7919u);
    float n3 = fbm(tau, wind_seed + 3u * 7919u);
    return wind_velocity * (1.0 + wind_gust * n0) + wind_turbulence * vec3(n1, n2, n3);
}
