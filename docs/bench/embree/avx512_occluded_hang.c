// Smallest reproduction of the hang that made groove cap Embree at isa=avx2 (thirteenth
// session, h2): Debian's Embree 3.13.5 (libembree3-3 3.13.5+dfsg-2) with its AVX-512 kernels
// never returns from rtcOccluded1M when
//   - the context is COHERENT (Embree then traces 16-wide packets on AVX-512),
//   - the scene holds an instance (here of a one-triangle scene, identity transform),
//   - the rays' directions differ in octant, and
//   - the stack below the caller holds non-zero bytes (earlier calls leave such bytes; here
//     scribble() writes them): a read of uninitialised stack memory inside Embree.
// Every input is initialised and within the API's rules (RTCRayHit array, stride
// sizeof(RTCRayHit), tnear 0 <= tfar inf, mask ~0, flags 0, id 0; rtcInitIntersectContext).
// isa=avx2 never hangs; avx512 returns when the stack is zero or without the instance.
//
//   cc -O1 -o /tmp/hang avx512_occluded_hang.c -lembree3
//   timeout 5 /tmp/hang isa=avx512 7 1 ffffffff   # hangs (exit 124)
//   timeout 5 /tmp/hang isa=avx512 7 1 0          # returns: "2 of 7 occluded"
//   timeout 5 /tmp/hang isa=avx2   7 1 ffffffff   # returns
//   timeout 5 /tmp/hang isa=avx512 7 0 ffffffff   # returns (no instance)
// Arguments: device config, ray count (<= 64), instance (0/1), stack word (hex; none: no scribble).
// Found on an AMD Zen 4 host; it reproduces unchanged on the Intel Xeon (AVX-512) host of the
// nineteenth session: the four lines above give 124, 0, 0, 0; 16 rays and the word 12345678 hang too.
#include <embree3/rtcore.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

__attribute__((noinline)) static void scribble(unsigned w) {
  volatile unsigned a[64 * 1024];
  for (int i = 0; i < 64 * 1024; i++) a[i] = w;
}

int main(int argc, char** argv) {
  const char* cfg = argc > 1 ? argv[1] : "isa=avx512";
  int nrays = argc > 2 ? atoi(argv[2]) : 7;
  int inst = argc > 3 ? atoi(argv[3]) : 1;
  if (nrays < 1 || nrays > 64) return 2;
  RTCDevice dev = rtcNewDevice(cfg);
  RTCScene scene = rtcNewScene(dev);
  RTCScene group = inst ? rtcNewScene(dev) : 0;
  RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
  float* v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, 3);
  unsigned* ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, 1);
  const float corners[9] = {-1, -1, 0, 1, -1, 0, 0, 1, 0};
  for (int i = 0; i < 9; i++) v[i] = corners[i];
  ix[0] = 0, ix[1] = 1, ix[2] = 2;
  rtcCommitGeometry(g);
  rtcAttachGeometry(inst ? group : scene, g);
  rtcReleaseGeometry(g);
  if (inst) {
    rtcCommitScene(group);
    RTCGeometry ig = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(ig, group);
    const float xf[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    rtcSetGeometryTransform(ig, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xf);
    rtcCommitGeometry(ig);
    rtcAttachGeometry(scene, ig);
    rtcReleaseGeometry(ig);
  }
  rtcCommitScene(scene);
  struct RTCRayHit rh[64];
  for (int k = 0; k < nrays; k++) {
    struct RTCRay* r = &rh[k].ray;
    r->org_x = 0.1f * k - 0.3f, r->org_y = 0, r->org_z = -3;
    r->dir_x = (k & 1) ? 0.3f : -0.3f, r->dir_y = (k & 2) ? 0.2f : -0.2f, r->dir_z = 1;
    r->tnear = 0, r->tfar = INFINITY, r->time = 0, r->mask = ~0u, r->id = 0, r->flags = 0;
    rh[k].hit.geomID = RTC_INVALID_GEOMETRY_ID;
  }
  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  if (argc > 4) scribble((unsigned)strtoul(argv[4], 0, 16));
  rtcOccluded1M(scene, &ctx, &rh[0].ray, nrays, sizeof(struct RTCRayHit));
  int occ = 0;
  for (int k = 0; k < nrays; k++) occ += rh[k].ray.tfar == -INFINITY;
  printf("%s n=%d inst=%d: %d of %d occluded\n", cfg, nrays, inst, occ, nrays);
  if (group) rtcReleaseScene(group);
  rtcReleaseScene(scene);
  rtcReleaseDevice(dev);
  return 0;
}
