/* The Embree side of `haze bench rays`: the same geometry and rays through Embree 3, timed on 1
 * and 2 threads. A benchmark tool only — haze never links Embree.
 *
 *   cc -O2 -o target/embree-rays benches/embree/rays.c -lembree3 -lpthread   (benches/embree/build.sh)
 *   target/embree-rays FILE [SECONDS]
 *
 * FILE is what `haze bench rays --embree` writes for it (haze::raybench::export; little-endian):
 *   "HZRB" u32 version (1)
 *   u32 triangles, then 9 f32 each (three vertices)
 *   u32 spheres, then 4 f32 each (centre, radius)
 *   u32 ray sets, each: u32 name length, name bytes, u32 rays, then 7 f32 each (o, d, t_max)
 *
 * Geometry is built as Embree's users build a static scene for speed (RTC_BUILD_QUALITY_HIGH,
 * no scene flags); spheres are Embree's own analytic sphere points. Rays go through rtcIntersect1
 * and rtcOccluded1 one at a time, as a path tracer casts them (incoherent context; coherent for
 * the camera set). Each (set, query, threads) is repeated over the whole set until SECONDS
 * (default 1) have passed. Prints one line per measurement:
 *   SET QUERY THREADS RAYS_PER_SECOND HITS
 * where HITS counts the rays of one pass over the set that hit (closest) or were occluded.
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    char name[64];
    uint32_t n;
    float *r; /* 7 floats per ray */
} RaySet;

static void fail(const char *what) {
    fprintf(stderr, "embree-rays: %s\n", what);
    exit(1);
}

static uint32_t read_u32(FILE *f) {
    uint32_t v;
    if (fread(&v, 4, 1, f) != 1) fail("truncated file");
    return v;
}

static float *read_floats(FILE *f, size_t n) {
    float *p = malloc(n * sizeof(float) + 1);
    if (!p) fail("out of memory");
    if (n && fread(p, sizeof(float), n, f) != n) fail("truncated file");
    return p;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

typedef struct {
    RTCScene scene;
    const RaySet *set;
    int occlusion, coherent;
    uint32_t begin, end;
    uint64_t hits;
} Job;

static void *work(void *arg) {
    Job *j = arg;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = j->coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    uint64_t hits = 0;
    for (uint32_t i = j->begin; i < j->end; i++) {
        const float *r = j->set->r + 7 * (size_t)i;
        if (j->occlusion) {
            struct RTCRay ray = {0};
            ray.org_x = r[0]; ray.org_y = r[1]; ray.org_z = r[2];
            ray.dir_x = r[3]; ray.dir_y = r[4]; ray.dir_z = r[5];
            ray.tnear = 0.0f; ray.tfar = r[6]; ray.mask = 0xFFFFFFFF;
            rtcOccluded1(j->scene, &ctx, &ray);
            hits += ray.tfar < 0.0f;
        } else {
            struct RTCRayHit rh = {0};
            rh.ray.org_x = r[0]; rh.ray.org_y = r[1]; rh.ray.org_z = r[2];
            rh.ray.dir_x = r[3]; rh.ray.dir_y = r[4]; rh.ray.dir_z = r[5];
            rh.ray.tnear = 0.0f; rh.ray.tfar = r[6]; rh.ray.mask = 0xFFFFFFFF;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(j->scene, &ctx, &rh);
            hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        }
    }
    j->hits = hits;
    return NULL;
}

/* One pass over the set on `threads` threads; returns the rays that hit. */
static uint64_t pass(RTCScene scene, const RaySet *set, int occlusion, int threads) {
    pthread_t t[16];
    Job jobs[16];
    uint64_t hits = 0;
    for (int k = 0; k < threads; k++) {
        jobs[k] = (Job){scene, set, occlusion, strcmp(set->name, "camera") == 0,
                        (uint32_t)((uint64_t)set->n * k / threads),
                        (uint32_t)((uint64_t)set->n * (k + 1) / threads), 0};
        if (threads == 1) work(&jobs[k]);
        else pthread_create(&t[k], NULL, work, &jobs[k]);
    }
    for (int k = 0; k < threads; k++) {
        if (threads > 1) pthread_join(t[k], NULL);
        hits += jobs[k].hits;
    }
    return hits;
}

int main(int argc, char **argv) {
    if (argc < 2) fail("usage: embree-rays FILE [SECONDS]");
    double seconds = argc > 2 ? atof(argv[2]) : 1.0;
    FILE *f = fopen(argv[1], "rb");
    if (!f) fail("cannot open the ray file");
    char magic[4];
    if (fread(magic, 1, 4, f) != 4 || memcmp(magic, "HZRB", 4) != 0) fail("not a haze ray file");
    if (read_u32(f) != 1) fail("unknown version");
    uint32_t ntri = read_u32(f);
    float *tri = read_floats(f, 9 * (size_t)ntri);
    uint32_t nsph = read_u32(f);
    float *sph = read_floats(f, 4 * (size_t)nsph);
    uint32_t nsets = read_u32(f);
    RaySet *sets = calloc(nsets, sizeof(RaySet));
    for (uint32_t s = 0; s < nsets; s++) {
        uint32_t len = read_u32(f);
        if (len >= sizeof sets[s].name) fail("ray set name too long");
        if (fread(sets[s].name, 1, len, f) != len) fail("truncated file");
        sets[s].n = read_u32(f);
        sets[s].r = read_floats(f, 7 * (size_t)sets[s].n);
    }
    fclose(f);

    RTCDevice device = rtcNewDevice("threads=1");
    if (!device) fail("rtcNewDevice failed");
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    double t0 = now();
    if (ntri) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                           3 * sizeof(float), 3 * (size_t)ntri);
        memcpy(v, tri, 9 * sizeof(float) * (size_t)ntri);
        unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                3 * sizeof(unsigned), ntri);
        for (uint32_t i = 0; i < 3 * ntri; i++) idx[i] = i;
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    if (nsph) {
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                           4 * sizeof(float), nsph);
        memcpy(v, sph, 4 * sizeof(float) * (size_t)nsph);
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene);
    printf("build %.6f\n", now() - t0);

    for (uint32_t s = 0; s < nsets; s++) {
        for (int occlusion = 0; occlusion < 2; occlusion++) {
            for (int threads = 1; threads <= 2; threads++) {
                uint64_t hits = pass(scene, &sets[s], occlusion, threads); /* warm-up */
                uint64_t rays = 0;
                double start = now(), elapsed;
                do {
                    pass(scene, &sets[s], occlusion, threads);
                    rays += sets[s].n;
                    elapsed = now() - start;
                } while (elapsed < seconds);
                printf("%s %s %d %.0f %llu\n", sets[s].name, occlusion ? "occlusion" : "closest",
                       threads, rays / elapsed, (unsigned long long)hits);
                fflush(stdout);
            }
        }
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return 0;
}
