// library: included by bushing_*.scad, renders nothing on its own.
// Flanged bushing: tube 32 x 35 mm on a 60 x 8 mm flange, 20 mm bore, a 20 -> 26 mm
// countersink at the top, four 6 mm bolt holes through the flange, one 4 mm cross hole.
// Every circle in `fn` facets. Written for this repository, CC0.
module bushing(fn) {
    $fn = fn;
    difference() {
        union() {
            cylinder(d = 60, h = 8);
            cylinder(d = 32, h = 35);
        }
        translate([0, 0, -1]) cylinder(d = 20, h = 37);
        translate([0, 0, 32]) cylinder(d1 = 20, d2 = 26, h = 3.001);
        for (a = [45 : 90 : 315]) rotate(a) translate([23, 0, -1]) cylinder(d = 6, h = 10);
        translate([0, 0, 22]) rotate([0, 90, 0]) cylinder(d = 4, h = 40);
    }
}
