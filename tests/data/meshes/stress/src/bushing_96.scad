// Flanged bushing (bushing.scad) with every circle in 96 facets (issue 32's hang 1).
// Written for this repository, CC0.
use <bushing.scad>
bushing(96);
