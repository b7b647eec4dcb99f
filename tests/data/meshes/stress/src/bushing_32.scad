// Flanged bushing (bushing.scad) with every circle in 32 facets: coarse facets, the
// 4 mm cross hole is a 32-gon. Written for this repository, CC0.
use <bushing.scad>
bushing(32);
