// The peer kernel for scene/benches/ray_sets.rs: tinybvh traces the ray sets that bench
// wrote (HOLOCAVE_RAY_DUMP=DIR), one ray at a time, on one thread and on two (alternate
// chunks of 4096 rays each), best of RUNS, and checks its answers against holocave's.
//
// Built and run by benches/peer_rays.sh, which fetches tinybvh (tiny_bvh.h) at a pinned
// commit; this file is the harness only.
//
//   tinybvh_rays DIR [RUNS] [BUILD]     BUILD: hq (SBVH, the default) or plain
//
// Prints, for the table: "rate <set> <threads> <Mrays/s>" (wall clock), "cpurate <set>
// <threads> <Mrays per CPU-second>" (the process's CPU time, both threads summed), "made
// <set> 1 <Mrays per CPU-second>" (one thread, each Ray made inside the timed loop from its
// origin and direction, see trace_made), and the agreement lines.

#define TINYBVH_IMPLEMENTATION
#include "tiny_bvh.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <time.h>
#include <vector>

using namespace tinybvh;

#if defined BVH_USEAVX2
typedef BVH8_CPU PeerBVH;
static const char* kernel = "BVH8_CPU (AVX2)";
#elif defined BVH_USESSE
typedef BVH4_CPU PeerBVH;
static const char* kernel = "BVH4_CPU (SSE)";
#else
typedef BVH PeerBVH;
static const char* kernel = "BVH (scalar)";
#endif

// A file of a u32 count followed by count records of `per` f32 each.
static std::vector<float> read_f32s(const std::string& path, uint32_t per, uint32_t& count)
{
	FILE* f = fopen(path.c_str(), "rb");
	if (!f) { fprintf(stderr, "cannot open %s\n", path.c_str()); exit(1); }
	if (fread(&count, 4, 1, f) != 1) { fprintf(stderr, "short %s\n", path.c_str()); exit(1); }
	std::vector<float> v((size_t)count * per);
	if (fread(v.data(), 4, v.size(), f) != v.size()) { fprintf(stderr, "short %s\n", path.c_str()); exit(1); }
	fclose(f);
	return v;
}

static double now()
{
	return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// CPU time this process has used, all threads (as ray_sets.rs measures its _cpu group).
static double cpu_now()
{
	timespec ts;
	clock_gettime( CLOCK_PROCESS_CPUTIME_ID, &ts );
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

enum Query { CLOSEST, OCCLUDED };

// Rays per chunk when two threads share a set (as in ray_sets.rs): thread k takes chunks
// k, k + step, ...
static const size_t CHUNK = 4096;

// Traces rays[begin, end); answers: hit distance (closest, +inf for a miss) or 1/0.
static void trace_range(const PeerBVH& bvh, Query q, Ray* rays, float* answer, size_t begin, size_t end)
{
	if (q == CLOSEST)
	{
		for (size_t i = begin; i < end; i++)
		{
			bvh.Intersect( rays[i] );
			answer[i] = rays[i].hit.t < BVH_FAR ? rays[i].hit.t : INFINITY;
		}
	}
	else
	{
		for (size_t i = begin; i < end; i++) answer[i] = bvh.IsOccluded( rays[i] ) ? 1.0f : 0.0f;
	}
}

// Traces n rays given as origin and direction (six floats each), each Ray made inside the
// loop with tinybvh's constructor (which normalises the direction and takes its inverse),
// as a renderer makes them: what holocave's own figures include (its queries take an
// origin and a direction), where the rates above time tinybvh on Rays made beforehand.
static void trace_made(const PeerBVH& bvh, Query q, const float* rv, float* answer, size_t n)
{
	for (size_t i = 0; i < n; i++)
	{
		const float* r = rv + i * 6;
		Ray ray( bvhvec3( r[0], r[1], r[2] ), bvhvec3( r[3], r[4], r[5] ) );
		if (q == CLOSEST)
		{
			bvh.Intersect( ray );
			answer[i] = ray.hit.t < BVH_FAR ? ray.hit.t : INFINITY;
		}
		else answer[i] = bvh.IsOccluded( ray ) ? 1.0f : 0.0f;
	}
}

// Traces chunks first, first + step, ... of n rays.
static void trace(const PeerBVH* bvh, Query q, Ray* rays, float* answer, size_t n, size_t first, size_t step)
{
	for (size_t begin = first * CHUNK; begin < n; begin += step * CHUNK)
		trace_range( *bvh, q, rays, answer, begin, std::min( n, begin + CHUNK ) );
}

int main(int argc, char** argv)
{
	if (argc < 2) { fprintf(stderr, "usage: %s DIR [RUNS] [hq|plain]\n", argv[0]); return 2; }
	const std::string dir = argv[1];
	const int runs = argc > 2 ? atoi(argv[2]) : 10;
	const bool hq = argc > 3 ? strcmp(argv[3], "plain") != 0 : true;

	uint32_t tris = 0;
	std::vector<float> tv = read_f32s(dir + "/triangles.bin", 9, tris);
	bvhvec4* verts = (bvhvec4*)malloc64( (size_t)tris * 3 * sizeof( bvhvec4 ) );
	for (size_t i = 0; i < (size_t)tris * 3; i++)
		verts[i] = bvhvec4( tv[i * 3], tv[i * 3 + 1], tv[i * 3 + 2], 0 );

	PeerBVH bvh;
	double t0 = now();
	if (hq) bvh.BuildHQ( verts, tris ); else bvh.Build( verts, tris );
	printf( "tinybvh %s, %s build: %u triangles in %.0f ms\n", kernel, hq ? "BuildHQ (SBVH)" : "Build", tris, (now() - t0) * 1000 );

	struct Set { const char* name; Query q; };
	const Set sets[3] = { { "primary", CLOSEST }, { "shadow", OCCLUDED }, { "diffuse", CLOSEST } };
	for (const Set& set : sets)
	{
		uint32_t n = 0, n2 = 0;
		std::vector<float> rv = read_f32s(dir + "/" + set.name + ".rays", 6, n);
		std::vector<float> ours = read_f32s(dir + "/" + set.name + ".t", 1, n2);
		if (n != n2) { fprintf(stderr, "%s: %u rays but %u answers\n", set.name, n, n2); return 1; }
		std::vector<Ray> fresh( n );
		for (size_t i = 0; i < n; i++)
		{
			const float* r = &rv[i * 6];
			fresh[i] = Ray( bvhvec3( r[0], r[1], r[2] ), bvhvec3( r[3], r[4], r[5] ) );
		}
		std::vector<Ray> rays( n );
		std::vector<float> answer( n );
		for (int threads = 1; threads <= 2; threads++)
		{
			double best = 1e30, best_cpu = 1e30;
			for (int run = 0; run < runs; run++)
			{
				memcpy( (void*)rays.data(), fresh.data(), n * sizeof( Ray ) );
				const double start = now(), cpu_start = cpu_now();
				if (threads == 1) trace_range( bvh, set.q, rays.data(), answer.data(), 0, n );
				else
				{
					std::thread other( trace, &bvh, set.q, rays.data(), answer.data(), (size_t)n, (size_t)1, (size_t)2 );
					trace( &bvh, set.q, rays.data(), answer.data(), n, 0, 2 );
					other.join();
				}
				best = std::min( best, now() - start );
				best_cpu = std::min( best_cpu, cpu_now() - cpu_start );
			}
			printf( "rate %s %d %.3f\n", set.name, threads, n / best * 1e-6 );
			printf( "cpurate %s %d %.3f\n", set.name, threads, n / best_cpu * 1e-6 );
		}
		{
			double best_cpu = 1e30;
			std::vector<float> made( n );
			for (int run = 0; run < runs; run++)
			{
				const double cpu_start = cpu_now();
				trace_made( bvh, set.q, rv.data(), made.data(), n );
				best_cpu = std::min( best_cpu, cpu_now() - cpu_start );
			}
			printf( "made %s 1 %.3f\n", set.name, n / best_cpu * 1e-6 );
		}
		// Agreement with holocave on the same rays.
		size_t hits_ours = 0, hits_peer = 0, both = 0, disagree = 0, far_t = 0;
		double max_rel = 0;
		for (size_t i = 0; i < n; i++)
		{
			const bool ho = set.q == CLOSEST ? std::isfinite( ours[i] ) : ours[i] > 0.5f;
			const bool hp = set.q == CLOSEST ? std::isfinite( answer[i] ) : answer[i] > 0.5f;
			hits_ours += ho, hits_peer += hp;
			if (ho != hp) { disagree++; continue; }
			if (set.q == CLOSEST && ho)
			{
				both++;
				const double rel = fabs( (double)ours[i] - answer[i] ) / std::max( 1.0, (double)ours[i] );
				max_rel = std::max( max_rel, rel );
				if (rel > 1e-4) far_t++;
			}
		}
		if (set.q == CLOSEST)
			printf( "agree %s: %u rays; hits holocave %zu, tinybvh %zu; hit/miss differs on %zu; "
				"of %zu hit by both, %zu differ in distance by > 1e-4 relative (largest %.2g)\n",
				set.name, n, hits_ours, hits_peer, disagree, both, far_t, max_rel );
		else
			printf( "agree %s: %u rays; occluded holocave %zu, tinybvh %zu; differs on %zu\n",
				set.name, n, hits_ours, hits_peer, disagree );
	}
	free64( verts );
	return 0;
}
