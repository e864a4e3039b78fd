/* Accuracy of formulas.h's vector functions against double libm (the portable twin; AVX2 gives the
 * same bits). gcc -O1 -ffp-contract=off -Inative/src tools/formulas_accuracy.c -lm && ./a.out */
#include <stdio.h>
#include <math.h>
#include "simd_portable.h"
#include "scene.h"
#include "estimators.h"
int main(void){
  double e_at=0,e_s=0,e_c=0,e_x=0; 
  for (long i=0;i<2000000;i+=8){
    float a[8],b[8],o1[8],o2[8],o3[8];
    for(int l=0;l<8;l++){ unsigned long k=(i+l)*2654435761u; a[l]=((k%100003)/100003.0-0.5)*4; b[l]=(((k/7)%99991)/99991.0-0.5)*4; }
    vf r=v_atan2(v_load(a),v_load(b)); v_store(o1,r);
    for(int l=0;l<8;l++){ double d=fabs(o1[l]-atan2((double)a[l],(double)b[l])); if(d>e_at)e_at=d; }
    float x[8]; for(int l=0;l<8;l++) x[l]=(a[l]*32.0f); /* |x| <= 64 */
    vf s,c; v_sincos(v_load(x),&s,&c); v_store(o1,s); v_store(o2,c);
    for(int l=0;l<8;l++){ double ds=fabs(o1[l]-sin((double)x[l])), dc=fabs(o2[l]-cos((double)x[l])); if(ds>e_s)e_s=ds; if(dc>e_c)e_c=dc; }
    for(int l=0;l<8;l++) x[l]=a[l]*30.0f;
    vf e=v_exp2(v_load(x)); v_store(o3,e);
    for(int l=0;l<8;l++){ double t=exp2((double)x[l]); double d=fabs(o3[l]-t)/t; if(d>e_x)e_x=d; }
  }
  printf("atan2 abs %.3g (ulp of pi %.3g)\nsin abs %.3g cos abs %.3g (|x|<=64)\nexp2 rel %.3g (ulp %.3g)\n", e_at, e_at/(M_PI*pow(2,-23)/2), e_s,e_c,e_x, e_x/pow(2,-23));
}
