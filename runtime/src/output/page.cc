// output/page.cc — Page (output/page.h): the self-contained page of the calibration and network
// reports.
#include "output/page.h"

#include <cctype>
#include <sstream>

#include "output/assets.h"
#include "base/format.h"

namespace vlt::output_internal {

nlohmann::json RecordJson(const JobRecord& record) {
  if (record.empty()) return nullptr;
  auto text = [](const std::string& s) { return s.empty() ? nlohmann::json(nullptr) : nlohmann::json(s); };
  return {{"customer", text(record.customer)},
          {"instrument",
           {{"make", text(record.instrument.make)},
            {"model", text(record.instrument.model)},
            {"serial", text(record.instrument.serial)}}},
          {"operator", text(record.operator_name)},
          {"place", text(record.place)},
          {"conditions", text(record.conditions)}};
}

std::string RecordLine(const JobRecord& record) {
  std::string line;
  auto add = [&](const char* label, const std::string& value) {
    if (value.empty()) return;
    line += (line.empty()
                 ? std::string(1, static_cast<char>(std::toupper(static_cast<unsigned char>(label[0])))) +
                       (label + 1)
                 : "; " + std::string(label)) +
            " " + value;
  };
  add("customer", record.customer);
  add("instrument", DescribeInstrument(record.instrument));
  add("operator", record.operator_name);
  add("place", record.place);
  add("conditions", record.conditions);
  return line.empty() ? line : line + "\n";
}

using base_internal::HtmlEscape;

std::string ScriptJson(const nlohmann::json& value) { return base_internal::ScriptSafe(value.dump()); }

// A self-contained page: header, sections of server-side tables, plotly.js for the figures. The
// element #vlt-status carries data-errors / data-plots for the browser tests (as report.html).
// The print script (PrintDesign). Plots are drawn at the window's width; before printing each is
// relaid out synchronously at the paper's (186 mm: A4 between the margins, which fits Letter too),
// scaled like its container, with a title too long for that width broken at a space; after
// printing it is responsive again. A WebGL figure (a 3-D scene) does not print: once drawn, a
// picture of it is placed after it for print. Header rows move into <thead>, which the browser
// repeats on every page a table continues on.
constexpr const char* kPrintScript = R"js((function(){
var saved=[];
function width(){var d=document.getElementById('vlt-print-width');return d?d.getBoundingClientRect().width:703;}
function wrap(t,w,size){if(!t||t.indexOf('<br>')>=0)return t;var per=0.55*(size||17);if(t.length*per<=w-20)return t;
var cut=t.lastIndexOf(' ',Math.floor(t.length/2)+8);if(cut<1)cut=t.indexOf(' ');return cut<1?t:t.slice(0,cut)+'<br>'+t.slice(cut+1);}
function fit(){if(!window.Plotly)return;var W=width(),main=document.querySelector('main');
var mw=main?main.getBoundingClientRect().width:0;saved=[];
document.querySelectorAll('.js-plotly-plot').forEach(function(p){var r=p.getBoundingClientRect().width,L=p._fullLayout;
if(!L||!r||!mw||p.classList.contains('vlt-screen-only'))return;var w=Math.min(r,W*Math.min(1,r/mw));
var t=L.title&&L.title.text,u={width:w};var nt=wrap(t,w,L.title&&L.title.font&&L.title.font.size);if(nt!==t)u['title.text']=nt;
saved.push([p,t]);try{Plotly.relayout(p,u);}catch(e){}});}
function unfit(){saved.forEach(function(x){var u={width:null,autosize:true};if(x[1]!==undefined)u['title.text']=x[1];
try{Plotly.relayout(x[0],u);}catch(e){}});saved=[];}
function snap(p){if(p.classList.contains('screen-only')||p.vltSnapped||!p._fullLayout||!p._fullLayout.scene||!window.Plotly)return;p.vltSnapped=true;
Plotly.toImage(p,{format:'png',width:900,height:700}).then(function(url){if(!p.isConnected||!p.parentNode)return;var i=new Image();i.src=url;i.className='vlt-print-img';
i.style.maxWidth='100%';i.alt='the 3-D view as drawn';p.parentNode.insertBefore(i,p.nextSibling);p.classList.add('vlt-screen-only');}).catch(function(){p.vltSnapped=false;});}
function snaps(){document.querySelectorAll('.js-plotly-plot').forEach(function(p){if(p.on&&!p.vltWatched){p.vltWatched=true;
p.on('plotly_afterplot',function(){snap(p);});}snap(p);});}
function heads(){document.querySelectorAll('table').forEach(function(t){if(t.tHead)return;var r=t.rows[0];
if(r&&r.cells.length&&Array.prototype.every.call(r.cells,function(c){return c.tagName==='TH';})){t.createTHead().appendChild(r);}});}
heads();snaps();window.addEventListener('load',function(){heads();snaps();setTimeout(snaps,500);});
window.addEventListener('beforeprint',function(){heads();fit();});window.addEventListener('afterprint',unfit);
})();)js";

std::string PrintDesign(const std::string& name) {
  const std::string box = "font-family:system-ui,sans-serif;font-size:8pt;color:#555";
  std::ostringstream os;
  os << "<style>@page{margin:15mm 12mm 16mm 12mm;@top-left{content:" << base_internal::CssString(name) << ";"
     << box << "}@bottom-right{content:\"Page \" counter(page) \" of \" counter(pages);" << box
     << "}}\n@media print{body{background:#fff;font-size:10px}"
        "header{background:#fff!important;color:#000!important;border-bottom:2px solid #1f3a5f;padding:0 0 6px "
        "0!important}header h1{font-size:16px}main{padding:0!important;max-width:none!important}"
        "section{border:none!important;border-radius:0;padding:0!important;margin:0 0 12px 0!important;"
        "break-inside:auto!important}h2{font-size:14px;break-after:avoid}"
        "table{font-size:8px;max-width:100%}th,td{white-space:normal!important;padding:1px 3px!important}"
        "td.l,th.l{overflow-wrap:break-word}th{position:static!important}"
        "thead{display:table-header-group}"
        "tr{break-inside:avoid}.scroll{max-height:none!important;overflow:visible!important}"
        ".plot{width:100%!important;break-inside:avoid}.modebar,.no-print,select{display:none!important}"
        ".vlt-screen-only{display:none!important}footer{padding:6px 0 0 0!important}}"
        "@media screen{.vlt-print-img{display:none}}</style>\n"
        "<div id=\"vlt-print-width\" style=\"position:absolute;visibility:hidden;width:186mm;height:0\"></div>\n"
     << "<script>" << kPrintScript << "</script>\n";
  return os.str();
}

std::string Page(const std::string& title, const std::string& subtitle, const std::string& body,
                 const std::string& script) {
  std::ostringstream os;
  os << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << HtmlEscape(title)
     << "</"
        "title>\n<script>window.vltErrors=[];window.onerror=function(m,s,l){window.vltErrors.push(String(m)+'"
        " (line '+l+')');"
        "var "
        "e=document.getElementById('vlt-status');if(e){e.textContent='error';e.setAttribute('data-errors',"
        "String(window.vltErrors.length));}};</script>\n"
        "<style>body{font-family:system-ui,sans-serif;margin:0;color:#1b2430;background:#f6f7f9}"
        "header{background:#1f3a5f;color:#fff;padding:18px 28px}header h1{margin:0 0 4px 0;font-size:22px}"
        "main{padding:8px 28px 40px 28px;max-width:1400px}section{background:#fff;border:1px solid "
        "#dde2e8;border-radius:6px;padding:14px 18px;margin:16px 0}"
        "h2{font-size:18px;margin:0 0 10px 0;color:#1f3a5f}table{border-collapse:collapse;font-size:13px}"
        "th,td{border-bottom:1px solid #e3e7ec;padding:3px "
        "8px;text-align:right;white-space:nowrap}th{background:#eef1f5}"
        "td.l,th.l{text-align:left}.ok{color:#1a7f37;font-weight:600}.bad{color:#b42318;font-weight:600}.na{"
        "color:#777}"
        ".note{font-size:12px;color:#555;max-width:1100px}.plot{width:100%;height:560px}"
        "</style>\n<script>"
     << output_internal::PlotlyJs() << "</script></head><body><header><h1>" << HtmlEscape(title) << "</h1><p>"
     << HtmlEscape(subtitle)
     << "</p></header><main><div id=\"vlt-status\" data-errors=\"0\" data-plots=\"0\" "
        "style=\"display:none\">pending</div>\n"
     << body << "</main><footer class=\"note\" style=\"padding:0 28px 20px\">vlt " << VLT_VERSION
     << " — plotly.js " << output_internal::PlotlyVersion()
     << " (MIT licence) is embedded in this page.</footer>\n<script>\n"
     << "(function(){var plots=0;function done(){plots++;var s=document.getElementById('vlt-status');"
        "s.setAttribute('data-plots',String(plots));if(window.vltErrors.length===0)s.textContent='plots-ok';}"
        "\n"
     << script << "\n})();\n</script>\n"
     << PrintDesign(title) << "</body></html>\n";
  return os.str();
}

}  // namespace vlt::output_internal
