//! The inline zoom of dense figures in the HTML report (style guide rule
//! 10): a figure of class `zoomable` zooms with the mouse wheel about the
//! pointer, pans by dragging and resets on double click, by changing its
//! SVG's `viewBox`; lines keep their width (`non-scaling-stroke`). No
//! network, no library: the script is inlined once per page.

/// CSS for zoomable figures.
pub const STYLE: &str = "figure.zoomable svg{cursor:zoom-in;touch-action:none}\
figure.zoomable svg polyline,figure.zoomable svg path,figure.zoomable svg line{vector-effect:non-scaling-stroke}\
figure.zoomable figcaption::after{content:' (wheel: zoom, drag: pan, double click: reset)';color:#888}";

/// The script: one handler set per `figure.zoomable svg`.
pub const SCRIPT: &str = r#"(function(){
document.querySelectorAll('figure.zoomable svg').forEach(function(svg){
  var vb0=svg.getAttribute('viewBox').split(/[ ,]+/).map(Number), vb=vb0.slice(), drag=null;
  function set(){svg.setAttribute('viewBox',vb.join(' '));}
  function pt(e){var r=svg.getBoundingClientRect();
    return [vb[0]+(e.clientX-r.left)/r.width*vb[2], vb[1]+(e.clientY-r.top)/r.height*vb[3]];}
  svg.addEventListener('wheel',function(e){e.preventDefault();
    var p=pt(e), k=e.deltaY<0?0.8:1.25, w=Math.min(vb0[2],vb[2]*k), h=Math.min(vb0[3],vb[3]*k);
    vb=[p[0]-(p[0]-vb[0])*w/vb[2], p[1]-(p[1]-vb[1])*h/vb[3], w, h]; set();},{passive:false});
  svg.addEventListener('mousedown',function(e){drag=[e.clientX,e.clientY,vb[0],vb[1]];});
  window.addEventListener('mouseup',function(){drag=null;});
  svg.addEventListener('mousemove',function(e){if(!drag)return;var r=svg.getBoundingClientRect();
    vb[0]=drag[2]-(e.clientX-drag[0])/r.width*vb[2]; vb[1]=drag[3]-(e.clientY-drag[1])/r.height*vb[3]; set();});
  svg.addEventListener('dblclick',function(){vb=vb0.slice(); set();});
});})();"#;
