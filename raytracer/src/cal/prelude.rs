//! The definitions every expression sees, in the global context.
//!
//! These follow Radiance's `rayinit.cal` (the file `func.c` loads before any
//! other): the same names with the same meaning, so that scene files written
//! for Radiance find what they expect. When a `rayinit.cal` is found on the
//! library's search path it is loaded instead, as Radiance does.

/// The ray channels, numbered as `func.c`'s `chanvalue`.
pub(crate) const CHANNELS: &str = "
Dx=$1; Dy=$2; Dz=$3; Nx=$4; Ny=$5; Nz=$6; Px=$7; Py=$8; Pz=$9;
T=$10; Rdot=$11; S=$12; Tx=$13; Ty=$14; Tz=$15;
Ix=$16; Iy=$17; Iz=$18; Jx=$19; Jy=$20; Jz=$21; Kx=$22; Ky=$23; Kz=$24;
Ts=$25; Lu=$26; Lv=$27;
";

/// rayinit.cal's library, written out here.
pub(crate) const PRELUDE: &str = "
{ argument count and the first ten real arguments }
AC = arg(0);
A1 = arg(1); A2 = arg(2); A3 = arg(3); A4 = arg(4); A5 = arg(5);
A6 = arg(6); A7 = arg(7); A8 = arg(8); A9 = arg(9); A10 = arg(10);

{ older names of the noise gradient }
noise3a(x,y,z) : noise3x(x,y,z);
noise3b(x,y,z) : noise3y(x,y,z);
noise3c(x,y,z) : noise3z(x,y,z);

{ vectors as functions of an index 1..3 }
D(i) = select(i, Dx, Dy, Dz);
N(i) = select(i, Nx, Ny, Nz);
P(i) = select(i, Px, Py, Pz);
noise3d(i,x,y,z) : select(i, noise3x(x,y,z), noise3y(x,y,z), noise3z(x,y,z));

{ library functions made safe at the edges of their domains }
bound(a,x,b) : if(a-x, a, if(x-b, b, x));
Acos(x) : acos(bound(-1,x,1));
Asin(x) : asin(bound(-1,x,1));
Atan2(y,x) : if(x*x+y*y, atan2(y,x), 0);
Exp(x) : if(-x-100, 0, exp(x));
Sqrt(x) : if(x, sqrt(x), 0);

PI : 3.14159265358979323846;
DEGREE : PI/180;
FTINY : 1e-7;

and(a,b) : if(a, b, a);
or(a,b) : if(a, a, b);
not(a) : if(a, -1, 1);
xor(a,b) : if(a, not(b), b);
abs(x) : if(x, x, -x);
sgn(x) : if(x, 1, if(-x, -1, 0));
sq(x) : x*x;
inside(a,x,b) : and(x-a, b-x);
frac(x) : x - floor(x);
mod(n,d) : n - floor(n/d)*d;
tri(n,d) : abs(d - mod(n-d, 2*d));
linterp(t,p0,p1) : (1-t)*p0 + t*p1;

{ colour and value filters named by patterns and textures }
noop(v) : v;
clip(v) : bound(0,v,1);
noneg(v) : if(v,v,0);
red(r,g,b) : if(r,r,0);
green(r,g,b) : if(g,g,0);
blue(r,g,b) : if(b,b,0);
grey(r,g,b) : noneg(.265074126*r + .670114631*g + .064811243*b);
clip_r(r,g,b) : bound(0,r,1);
clip_g(r,g,b) : bound(0,g,1);
clip_b(r,g,b) : bound(0,b,1);
clipgrey(r,g,b) : min(grey(r,g,b),1);

{ vector algebra on index functions such as D, N and P }
dot(v1,v2) : v1(1)*v2(1) + v1(2)*v2(2) + v1(3)*v2(3);
cross(i,v1,v2) : select(i, v1(2)*v2(3) - v1(3)*v2(2),
			v1(3)*v2(1) - v1(1)*v2(3),
			v1(1)*v2(2) - v1(2)*v2(1));

fade(near_val,far_val,dist) : far_val +
		if(16-dist, (near_val-far_val)/(1+dist*dist), 0);

{ cubic curves }
hermite(p0,p1,r0,r1,t) : p0 * ((2*t-3)*t*t+1) +
			p1 * (-2*t+3)*t*t +
			r0 * (((t-2)*t+1)*t) +
			r1 * ((t-1)*t*t);
bezier(p1,p2,p3,p4,t) : p1 * (1+t*(-3+t*(3-t))) +
			p2 * 3*t*(1+t*(-2+t)) +
			p3 * 3*t*t*(1-t) +
			p4 * t*t*t;
bspline(pp,p0,p1,pn,t) : pp * (1/6+t*(-.5+t*(.5-1/6*t))) +
			p0 * (2/3+t*t*(-1+.5*t)) +
			p1 * (1/6+t*(.5+t*(.5-.5*t))) +
			pn * (1/6*t*t*t);

{ summed noise over octaves from scale s down to 1 }
turbulence(x,y,z,s) : if(s-1.01, 0, abs(noise3(x/s,y/s,z/s)*s) +
			turbulence(x,y,z,2*s));
turbulencex(x,y,z,s) : if(s-1.01, 0,
			sgn(noise3(x/s,y/s,z/s))*noise3x(x/s,y/s,z/s) +
			turbulencex(x,y,z,2*s));
turbulencey(x,y,z,s) : if(s-1.01, 0,
			sgn(noise3(x/s,y/s,z/s))*noise3y(x/s,y/s,z/s) +
			turbulencey(x,y,z,2*s));
turbulencez(x,y,z,s) : if(s-1.01, 0,
			sgn(noise3(x/s,y/s,z/s))*noise3z(x/s,y/s,z/s) +
			turbulencez(x,y,z,2*s));

{ uniform (0,1) to normal distribution (rational approximation) }
un2`P.(t) : t - (2.515517+t*(.802853+t*.010328))/
		(1+t*(1.432788+t*(.189269+t*.001308)));
un1`P.(p) : un2`P.(sqrt(-2*log(p)));
unif2norm(p) : if(.5-p, -un1`P.(p), un1`P.(1-p));
nrand(x) = unif2norm(rand(x));

{ (u,v) in the plane of a planar surface: U from the projected z axis }
crosslen`P. = Nx*Nx + Ny*Ny;
U = if(crosslen`P. - FTINY, (Py*Nx - Px*Ny)/crosslen`P., Px);
V = if(crosslen`P. - FTINY, Pz - Nz*(Px*Nx + Py*Ny)/crosslen`P., Py);

{ hemisphere coordinates for the *func and *data types: the last three
  real arguments are an unnormalised up vector }
Vux`P. = arg(AC-1)*NzP - arg(AC)*NyP;
Vuy`P. = arg(AC)*NxP - arg(AC-2)*NzP;
Vuz`P. = arg(AC-2)*NyP - arg(AC-1)*NxP;
vnorm`P. = 1/sqrt(Vux`P.*Vux`P. + Vuy`P.*Vuy`P. + Vuz`P.*Vuz`P.);
Vnx`P. = Vux`P.*vnorm`P.;
Vny`P. = Vuy`P.*vnorm`P.;
Vnz`P. = Vuz`P.*vnorm`P.;
Unx`P. = NyP*Vnz`P. - NzP*Vny`P.;
Uny`P. = NzP*Vnx`P. - NxP*Vnz`P.;
Unz`P. = NxP*Vny`P. - NyP*Vnx`P.;
Ldx(dx,dy,dz) = dx*Unx`P. + dy*Uny`P. + dz*Unz`P.;
Ldy(dx,dy,dz) = dx*Vnx`P. + dy*Vny`P. + dz*Vnz`P.;
Ldz(dx,dy,dz) = dx*NxP + dy*NyP + dz*NzP;
{ the incident direction in those coordinates }
Idx = Ldx(-Dx,-Dy,-Dz);
Idy = Ldy(-Dx,-Dy,-Dz);
Idz = RdotP;
";
