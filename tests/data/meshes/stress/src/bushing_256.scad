// Flanged bushing (bushing.scad) with every circle in 256 facets: fine facets, a
// 0.25 mm chord on the 20 mm bore and 0.05 mm on the 4 mm cross hole.
// Written for this repository, CC0.
use <bushing.scad>
bushing(256);
