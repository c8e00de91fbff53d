// The smallest kernel: lets the tests check that a device builds and runs programs at all, and
// (with -DMCTSTEREO_SMOKE_BUILD_ERROR) that a failed build reports its log.
#ifdef MCTSTEREO_SMOKE_BUILD_ERROR
#error deliberate build error
#endif
__kernel void add_one(__global int* data) { data[get_global_id(0)] += 1; }
