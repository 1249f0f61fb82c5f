<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>
<qgis version="3.22.16-Białowieża" styleCategories="Symbology">
  <pipe-data-defined-properties>
    <Option type="Map">
      <Option name="name" type="QString" value=""/>
      <Option name="properties"/>
      <Option name="type" type="QString" value="collection"/>
    </Option>
  </pipe-data-defined-properties>
  <pipe>
    <provider>
      <resampling maxOversampling="2" zoomedOutResamplingMethod="nearestNeighbour" enabled="false" zoomedInResamplingMethod="nearestNeighbour"/>
    </provider>
    <rasterrenderer band="1" alphaBand="-1" classificationMax="1" nodataColor="" opacity="1" type="singlebandpseudocolor" classificationMin="0">
      <minMaxOrigin>
        <limits>None</limits>
        <extent>WholeRaster</extent>
        <statAccuracy>Estimated</statAccuracy>
        <cumulativeCutLower>0.02</cumulativeCutLower>
        <cumulativeCutUpper>0.98</cumulativeCutUpper>
        <stdDevFactor>2</stdDevFactor>
      </minMaxOrigin>
      <rastershader>
        <colorrampshader clip="0" maximumValue="1" minimumValue="0" colorRampType="INTERPOLATED" classificationMode="1" labelPrecision="6">
          <colorramp name="[source]" type="gradient">
            <Option type="Map">
              <Option name="color1" type="QString" value="68,1,84,255"/>
              <Option name="color2" type="QString" value="253,231,37,255"/>
              <Option name="discrete" type="QString" value="0"/>
              <Option name="rampType" type="QString" value="gradient"/>
              <Option name="stops" type="QString" value="0.0196078;70,8,92,255:0.0392157;71,16,99,255:0.0588235;72,23,105,255:0.0784314;72,29,111,255:0.0980392;72,36,117,255:0.117647;71,42,122,255:0.137255;70,48,126,255:0.156863;69,55,129,255:0.176471;67,61,132,255:0.196078;65,66,135,255:0.215686;63,72,137,255:0.235294;61,78,138,255:0.254902;58,83,139,255:0.27451;56,89,140,255:0.294118;53,94,141,255:0.313725;51,99,141,255:0.333333;49,104,142,255:0.352941;46,109,142,255:0.372549;44,113,142,255:0.392157;42,118,142,255:0.411765;41,123,142,255:0.431373;39,128,142,255:0.45098;37,132,142,255:0.470588;35,137,142,255:0.490196;33,142,141,255:0.509804;32,146,140,255:0.529412;31,151,139,255:0.54902;30,156,137,255:0.568627;31,161,136,255:0.588235;33,165,133,255:0.607843;36,170,131,255:0.627451;40,174,128,255:0.647059;46,179,124,255:0.666667;53,183,121,255:0.686275;61,188,116,255:0.705882;70,192,111,255:0.72549;80,196,106,255:0.745098;90,200,100,255:0.764706;101,203,94,255:0.784314;112,207,87,255:0.803922;124,210,80,255:0.823529;137,213,72,255:0.843137;149,216,64,255:0.862745;162,218,55,255:0.882353;176,221,47,255:0.901961;189,223,38,255:0.921569;202,225,31,255:0.941176;216,226,25,255:0.960784;229,228,25,255:0.980392;241,229,29,255"/>
            </Option>
            <prop k="color1" v="68,1,84,255"/>
            <prop k="color2" v="253,231,37,255"/>
            <prop k="discrete" v="0"/>
            <prop k="rampType" v="gradient"/>
            <prop k="stops" v="0.0196078;70,8,92,255:0.0392157;71,16,99,255:0.0588235;72,23,105,255:0.0784314;72,29,111,255:0.0980392;72,36,117,255:0.117647;71,42,122,255:0.137255;70,48,126,255:0.156863;69,55,129,255:0.176471;67,61,132,255:0.196078;65,66,135,255:0.215686;63,72,137,255:0.235294;61,78,138,255:0.254902;58,83,139,255:0.27451;56,89,140,255:0.294118;53,94,141,255:0.313725;51,99,141,255:0.333333;49,104,142,255:0.352941;46,109,142,255:0.372549;44,113,142,255:0.392157;42,118,142,255:0.411765;41,123,142,255:0.431373;39,128,142,255:0.45098;37,132,142,255:0.470588;35,137,142,255:0.490196;33,142,141,255:0.509804;32,146,140,255:0.529412;31,151,139,255:0.54902;30,156,137,255:0.568627;31,161,136,255:0.588235;33,165,133,255:0.607843;36,170,131,255:0.627451;40,174,128,255:0.647059;46,179,124,255:0.666667;53,183,121,255:0.686275;61,188,116,255:0.705882;70,192,111,255:0.72549;80,196,106,255:0.745098;90,200,100,255:0.764706;101,203,94,255:0.784314;112,207,87,255:0.803922;124,210,80,255:0.823529;137,213,72,255:0.843137;149,216,64,255:0.862745;162,218,55,255:0.882353;176,221,47,255:0.901961;189,223,38,255:0.921569;202,225,31,255:0.941176;216,226,25,255:0.960784;229,228,25,255:0.980392;241,229,29,255"/>
          </colorramp>
          <item label="0" alpha="255" color="#440154" value="0"/>
          <item label="0.0196" alpha="255" color="#46085c" value="0.0196078"/>
          <item label="0.0392" alpha="255" color="#471063" value="0.0392157"/>
          <item label="0.0588" alpha="255" color="#481769" value="0.0588235"/>
          <item label="0.0784" alpha="255" color="#481d6f" value="0.0784314"/>
          <item label="0.098" alpha="255" color="#482475" value="0.0980392"/>
          <item label="0.118" alpha="255" color="#472a7a" value="0.117647"/>
          <item label="0.137" alpha="255" color="#46307e" value="0.137255"/>
          <item label="0.157" alpha="255" color="#453781" value="0.156863"/>
          <item label="0.176" alpha="255" color="#433d84" value="0.176471"/>
          <item label="0.196" alpha="255" color="#414287" value="0.196078"/>
          <item label="0.216" alpha="255" color="#3f4889" value="0.215686"/>
          <item label="0.235" alpha="255" color="#3d4e8a" value="0.235294"/>
          <item label="0.255" alpha="255" color="#3a538b" value="0.254902"/>
          <item label="0.275" alpha="255" color="#38598c" value="0.27451"/>
          <item label="0.294" alpha="255" color="#355e8d" value="0.294118"/>
          <item label="0.314" alpha="255" color="#33638d" value="0.313725"/>
          <item label="0.333" alpha="255" color="#31688e" value="0.333333"/>
          <item label="0.353" alpha="255" color="#2e6d8e" value="0.352941"/>
          <item label="0.373" alpha="255" color="#2c718e" value="0.372549"/>
          <item label="0.392" alpha="255" color="#2a768e" value="0.392157"/>
          <item label="0.412" alpha="255" color="#297b8e" value="0.411765"/>
          <item label="0.431" alpha="255" color="#27808e" value="0.431373"/>
          <item label="0.451" alpha="255" color="#25848e" value="0.45098"/>
          <item label="0.471" alpha="255" color="#23898e" value="0.470588"/>
          <item label="0.49" alpha="255" color="#218e8d" value="0.490196"/>
          <item label="0.51" alpha="255" color="#20928c" value="0.509804"/>
          <item label="0.529" alpha="255" color="#1f978b" value="0.529412"/>
          <item label="0.549" alpha="255" color="#1e9c89" value="0.54902"/>
          <item label="0.569" alpha="255" color="#1fa188" value="0.568627"/>
          <item label="0.588" alpha="255" color="#21a585" value="0.588235"/>
          <item label="0.608" alpha="255" color="#24aa83" value="0.607843"/>
          <item label="0.627" alpha="255" color="#28ae80" value="0.627451"/>
          <item label="0.647" alpha="255" color="#2eb37c" value="0.647059"/>
          <item label="0.667" alpha="255" color="#35b779" value="0.666667"/>
          <item label="0.686" alpha="255" color="#3dbc74" value="0.686275"/>
          <item label="0.706" alpha="255" color="#46c06f" value="0.705882"/>
          <item label="0.725" alpha="255" color="#50c46a" value="0.72549"/>
          <item label="0.745" alpha="255" color="#5ac864" value="0.745098"/>
          <item label="0.765" alpha="255" color="#65cb5e" value="0.764706"/>
          <item label="0.784" alpha="255" color="#70cf57" value="0.784314"/>
          <item label="0.804" alpha="255" color="#7cd250" value="0.803922"/>
          <item label="0.824" alpha="255" color="#89d548" value="0.823529"/>
          <item label="0.843" alpha="255" color="#95d840" value="0.843137"/>
          <item label="0.863" alpha="255" color="#a2da37" value="0.862745"/>
          <item label="0.882" alpha="255" color="#b0dd2f" value="0.882353"/>
          <item label="0.902" alpha="255" color="#bddf26" value="0.901961"/>
          <item label="0.922" alpha="255" color="#cae11f" value="0.921569"/>
          <item label="0.941" alpha="255" color="#d8e219" value="0.941176"/>
          <item label="0.961" alpha="255" color="#e5e419" value="0.960784"/>
          <item label="0.98" alpha="255" color="#f1e51d" value="0.980392"/>
          <item label="1" alpha="255" color="#fde725" value="1"/>
          <rampLegendSettings useContinuousLegend="1" minimumLabel="" maximumLabel="" prefix="" direction="0" suffix=" m" orientation="2">
            <numericFormat id="basic">
              <Option type="Map">
                <Option name="decimal_separator" type="QChar" value=""/>
                <Option name="decimals" type="int" value="3"/>
                <Option name="rounding_type" type="int" value="0"/>
                <Option name="show_plus" type="bool" value="false"/>
                <Option name="show_thousand_separator" type="bool" value="true"/>
                <Option name="show_trailing_zeros" type="bool" value="false"/>
                <Option name="thousand_separator" type="QChar" value=""/>
              </Option>
            </numericFormat>
          </rampLegendSettings>
        </colorrampshader>
      </rastershader>
    </rasterrenderer>
    <brightnesscontrast gamma="1" contrast="0" brightness="0"/>
    <huesaturation grayscaleMode="0" colorizeGreen="128" saturation="0" invertColors="0" colorizeBlue="128" colorizeRed="255" colorizeOn="0" colorizeStrength="100"/>
    <rasterresampler maxOversampling="2"/>
    <resamplingStage>resamplingFilter</resamplingStage>
  </pipe>
  <blendMode>0</blendMode>
</qgis>
