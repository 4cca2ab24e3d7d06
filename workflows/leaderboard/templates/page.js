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
