"""The leaderboard page's stylesheet (STYLE) and its script (SCRIPT: the tooltips and the
filters), inlined into index.html by page.py so that the page works offline."""

STYLE = """
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0;color:#222;
background:#fafafa}
header,section{max-width:1180px;margin:0 auto;padding:10px 22px}
section{background:#fff;border:1px solid #ddd;border-radius:6px;margin:18px auto}
h1{font-size:24px;margin:14px 0 6px}h2{font-size:20px;margin:8px 0}
h3{font-size:16px;margin:14px 0 6px}
.note{color:#555;font-size:13.5px}
.grid{stroke:#e4e4e4}.stripline{stroke:#bbb;stroke-dasharray:3 3}
.tick{font-size:11.5px;fill:#444}.axis{font-size:13px;fill:#222}.strip{font-size:11px;fill:#777}
.band{fill:#f3d9a4;opacity:.55}.bandlabel{font-size:11.5px;fill:#8a5a00}
.realtime{stroke:#c00;stroke-width:1.5;stroke-dasharray:6 4}
.rtlabel{font-size:12px;fill:#c00;paint-order:stroke;stroke:#fff;stroke-width:3px;pointer-events:none}
.front{fill:none;stroke:#333;stroke-width:1.3;stroke-dasharray:5 3}
.pt{cursor:pointer}.pt:hover{stroke-width:3}
.ulabel{font-size:13px;font-weight:600;paint-order:stroke;stroke:#fff;stroke-width:3px}
.flabel{font-size:11px;fill:#333;paint-order:stroke;stroke:#fff;stroke-width:3px}
.leader{stroke:#888;stroke-width:.8}
.even{fill:#fff}.odd{fill:#f5f7fa}.brow:hover rect{fill:#ffeebb}
.hidden{display:none}
.filters{display:flex;flex-wrap:wrap;gap:4px 18px;font-size:13.5px;margin:6px 0}
.filters fieldset{border:1px solid #ddd;border-radius:4px;padding:2px 8px}
.filters label{margin-right:8px;white-space:nowrap}
.swatch{display:inline-block;width:10px;height:10px;border-radius:2px;margin-right:3px}
table.rank{border-collapse:collapse;font-size:13px;margin:4px 0 8px}
table.rank td,table.rank th{border-bottom:1px solid #e6e6e6;padding:2px 8px;text-align:left}
table.rank th{background:#f0f2f5}tr.userrow td{background:#fff4e0;font-weight:600}
.cols{display:flex;flex-wrap:wrap;gap:14px}.cols>div{flex:1 1 520px}
#tip{position:fixed;z-index:10;max-width:560px;background:#fffff4;border:1px solid #999;
border-radius:4px;padding:6px 9px;font-size:13px;box-shadow:0 2px 8px rgba(0,0,0,.2);
pointer-events:none}
#tip .t{font-weight:700}
.users{background:#fff4e0;border:1px solid #f0c070;border-radius:5px;padding:6px 12px}
svg{max-width:100%;height:auto}
"""

SCRIPT = """
(function(){
  var tip=document.getElementById('tip');
  function place(e){
    var x=e.clientX+14,y=e.clientY+14,w=tip.offsetWidth,h=tip.offsetHeight;
    if(x+w>window.innerWidth-8)x=Math.max(8,e.clientX-w-14);
    if(y+h>window.innerHeight-8)y=Math.max(8,e.clientY-h-14);
    tip.style.left=x+'px';tip.style.top=y+'px';
  }
  document.addEventListener('mouseover',function(e){
    var el=e.target.closest?e.target.closest('[data-tip]'):null;
    if(!el){tip.hidden=true;return;}
    var lines=JSON.parse(el.getAttribute('data-tip'));
    tip.textContent='';
    lines.forEach(function(line,i){
      var d=document.createElement('div');d.textContent=line;
      if(!i)d.className='t';tip.appendChild(d);
    });
    tip.hidden=false;place(e);
  });
  document.addEventListener('mousemove',function(e){if(!tip.hidden)place(e);});
  function apply(sec){
    var on={};
    sec.querySelectorAll('.filters input').forEach(function(cb){
      (on[cb.getAttribute('data-facet')]=on[cb.getAttribute('data-facet')]||{})[cb.value]=cb.checked;
    });
    sec.querySelectorAll('.f').forEach(function(el){
      var show=['source','model','mesh'].every(function(k){
        var v=el.getAttribute('data-'+k);
        return !(k in on)||v===null||on[k][v]!==false;
      });
      el.classList.toggle('hidden',!show);
    });
  }
  document.querySelectorAll('section.case').forEach(function(sec){
    sec.querySelectorAll('.filters input').forEach(function(cb){
      cb.addEventListener('change',function(){apply(sec);});
    });
    sec.querySelectorAll('button.only').forEach(function(b){
      b.addEventListener('click',function(){
        sec.querySelectorAll('.filters input[data-facet="source"]').forEach(function(cb){
          cb.checked=(b.getAttribute('data-value')==='*'||cb.value===b.getAttribute('data-value'));
        });
        apply(sec);
      });
    });
  });
})();
"""
